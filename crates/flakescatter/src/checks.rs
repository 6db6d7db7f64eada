//! The model settings every front end checks — the command line's flags, the Python
//! keywords and the `analyze` manifest's keys — with one rule and one message each; the
//! caller puts its own name for the setting in front (`--n`, `n=`, `coating.n`).
//!
//! ```
//! use flakescatter::checks::{coat_index, window};
//!
//! assert_eq!(coat_index(1.5), Ok(1.5));
//! let e = coat_index(0.9).unwrap_err();
//! assert_eq!(format!("--n {e}"), "--n 0.9: the refractive index must be a finite number >= 1");
//! assert!(window(4).is_err() && window(5).is_ok());
//! ```

/// A setting out of its range; the message starts with the value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingError {
    /// A clear-coat index that is not a finite number ≥ 1.
    #[error("{0}: the refractive index must be a finite number >= 1")]
    CoatIndex(f64),
    /// A least-squares window that is not an odd number of pixels ≥ 3.
    #[error("{0}: the least-squares window must be an odd number of pixels >= 3")]
    Window(usize),
    /// A statistics tile that is not a finite length > 0 µm.
    #[error("{0}: the tile side must be a finite length > 0 µm")]
    Tile(f64),
}

/// The clear coat's real index, checked: finite and ≥ 1.
///
/// # Errors
/// [`SettingError::CoatIndex`].
pub fn coat_index(n: f64) -> Result<f64, SettingError> {
    if n.is_finite() && n >= 1.0 {
        Ok(n)
    } else {
        Err(SettingError::CoatIndex(n))
    }
}

/// The side of the least-squares window of the local normals, pixels, checked: odd and
/// ≥ 3.
///
/// # Errors
/// [`SettingError::Window`].
pub fn window(k: usize) -> Result<usize, SettingError> {
    if k >= 3 && !k.is_multiple_of(2) {
        Ok(k)
    } else {
        Err(SettingError::Window(k))
    }
}

/// The side of the statistics tiles, µm, checked: finite and > 0.
///
/// # Errors
/// [`SettingError::Tile`].
pub fn tile_um(side: f64) -> Result<f64, SettingError> {
    if side.is_finite() && side > 0.0 {
        Ok(side)
    } else {
        Err(SettingError::Tile(side))
    }
}
