//! The range checks of a manifest, one function per table. The first key out of range
//! is the error, the tables checked in the order name, `[maps]`, `[stack]`,
//! `[instrument]`, `[coating]`, `[measured]`, `[paint]`, `[stats]`, `[models]`.

use super::{
    CoatingSection, InstrumentSection, Manifest, ManifestError, Maps, MeasuredSection,
    ModelsSection, PaintSection, StackSection, StatsSection,
};

impl Manifest {
    /// Checks every value's range.
    ///
    /// # Errors
    /// [`ManifestError`] naming the first key out of range.
    pub fn validate(&self, file: &str) -> Result<(), ManifestError> {
        check_name(self.name.as_deref(), file)?;
        check_maps(&self.maps, file)?;
        check_stack(&self.stack, file)?;
        check_instrument(&self.instrument, file)?;
        check_coating(&self.coating, file)?;
        if let Some(ms) = &self.measured {
            check_measured(ms, file)?;
        }
        if let Some(ps) = &self.paint {
            check_paint(ps, file)?;
        }
        check_stats(&self.stats, file)?;
        check_models(&self.models, self.measured.is_some(), file)
    }
}

/// The error of `key` in `file`.
fn bad(file: &str, key: &str, msg: String) -> Result<(), ManifestError> {
    Err(ManifestError {
        file: file.to_owned(),
        message: format!("key `{key}`: {msg}"),
    })
}

/// `name`: it names the report folder.
fn check_name(name: Option<&str>, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if let Some(n) = name
        && (n.is_empty()
            || !n
                .chars()
                .all(|c| c.is_alphanumeric() || matches!(c, '-' | '_' | '.'))
            || n.starts_with('.'))
    {
        return bad(
            "name",
            format!("`{n}`: use letters, digits, `-`, `_` and `.` (it names the report folder)"),
        );
    }
    Ok(())
}

/// `[maps]`.
fn check_maps(m: &Maps, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if m.files.is_empty() {
        return bad("maps.files", "no map listed".into());
    }
    if !m.intensity.is_empty() && m.intensity_suffix.is_some() {
        return bad(
            "maps.intensity",
            "give either `maps.intensity` (one per map) or `maps.intensity_suffix`, not both"
                .into(),
        );
    }
    if let Some(c) = m.cutoff
        && !c.is_finite()
    {
        return bad("maps.cutoff", format!("{c} is not a finite number"));
    }
    if m.intensity_channel.is_some() && (!m.intensity.is_empty() || m.intensity_suffix.is_some()) {
        return bad(
            "maps.intensity_channel",
            "give either an intensity channel of the map files or intensity files (`maps.intensity`, `maps.intensity_suffix`), not both"
                .into(),
        );
    }
    if let Err(e) = m.channels() {
        return Err(ManifestError {
            file: file.to_string(),
            message: e,
        });
    }
    if m.cutoff.is_none() && m.intensity_channel.is_some() {
        return bad(
            "maps.cutoff",
            "an intensity channel is given but no cutoff to apply it with".into(),
        );
    }
    if m.cutoff.is_none() && (!m.intensity.is_empty() || m.intensity_suffix.is_some()) {
        return bad(
            "maps.cutoff",
            "intensity maps are given but no cutoff to apply them with".into(),
        );
    }
    if let Some([x, y]) = m.pixel_um
        && !(x.is_finite() && x > 0.0 && y.is_finite() && y > 0.0)
    {
        return bad(
            "maps.pixel_um",
            format!("[{x}, {y}]: must be finite and > 0 µm"),
        );
    }
    if let Some(z) = &m.z_unit
        && !matches!(z.as_str(), "um" | "nm" | "m")
    {
        return bad("maps.z_unit", format!("`{z}`: expected um, nm or m"));
    }
    Ok(())
}

/// `[stack]`.
fn check_stack(s: &StackSection, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if flakescatter_confocal::PeakMethod::from_name(&s.peak).is_none() {
        return bad(
            "stack.peak",
            format!(
                "`{}`: expected argmax, parabolic, gaussian or centroid",
                s.peak
            ),
        );
    }
    if let Some(v) = s.min_signal
        && !(v.is_finite() && (0.0..=1.0).contains(&v))
    {
        return bad("stack.min_signal", format!("{v}: expected [0, 1]"));
    }
    if let Some(z) = s.z_step_um
        && !(z.is_finite() && z > 0.0)
    {
        return bad("stack.z_step_um", format!("{z}: must be finite and > 0 µm"));
    }
    if let Some(p) = &s.first_page
        && !matches!(p.as_str(), "bottom" | "top")
    {
        return bad("stack.first_page", format!("`{p}`: expected bottom or top"));
    }
    Ok(())
}

/// `[instrument]`.
fn check_instrument(i: &InstrumentSection, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if !(i.z_step_um.is_finite() && i.z_step_um >= 0.0) {
        return bad(
            "instrument.z_step_um",
            format!("{}: must be finite and >= 0 µm", i.z_step_um),
        );
    }
    if !(i.noise_um.is_finite() && i.noise_um >= 0.0) {
        return bad(
            "instrument.noise_um",
            format!("{}: must be finite and >= 0 µm", i.noise_um),
        );
    }
    if i.min_pixels < 3 {
        return bad(
            "instrument.min_pixels",
            format!("{}: must be at least 3", i.min_pixels),
        );
    }
    Ok(())
}

/// `[coating]`.
fn check_coating(c: &CoatingSection, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if let Err(e) = crate::checks::coat_index(c.n) {
        return bad("coating.n", e.to_string());
    }
    if let Some([n, k]) = c.flake_index
        && flakescatter_optics::flake::FlakeReflectance::complex(n, k).is_err()
    {
        return bad(
            "coating.flake_index",
            format!("[{n}, {k}]: not a usable complex index"),
        );
    }
    match (
        &c.flake_stack,
        c.flake_index,
        &c.flake_core,
        c.wavelength_nm,
    ) {
        (None, _, Some(_), _) => {
            return bad(
                "coating.flake_core",
                "a core is the core of a `flake_stack`; give the stack".into(),
            );
        }
        (None, _, _, Some(_)) => {
            return bad(
                "coating.wavelength_nm",
                "the wavelength of a `flake_stack`; without a stack the models are monochromatic and need none".into(),
            );
        }
        (Some(_), Some(_), _, _) => {
            return bad(
                "coating.flake_stack",
                "give `flake_index` or `flake_stack`, not both".into(),
            );
        }
        (Some(_), None, _, None) => {
            return bad(
                "coating.wavelength_nm",
                "needed with `flake_stack`: a stack reflects differently at every wavelength (nm)"
                    .into(),
            );
        }
        (Some(stack), None, core, Some(wl)) => {
            if let Err(e) = crate::film::stack_flake(stack, core.as_deref(), wl) {
                use crate::film::StackFlakeError as E;
                let key = match e {
                    E::Wavelength(_) => "coating.wavelength_nm",
                    E::Core(_) => "coating.flake_core",
                    E::Spec(_) | E::AtWavelength(_) => "coating.flake_stack",
                };
                return bad(key, e.to_string());
            }
        }
        (None, _, None, None) => {}
    }
    Ok(())
}

/// `[measured]`.
fn check_measured(ms: &MeasuredSection, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if ms.files.is_empty() {
        return bad("measured.files", "no file listed".into());
    }
    if ms.kind.parse::<crate::compare::MeasuredKind>().is_err() {
        return bad(
            "measured.kind",
            format!(
                "`{}`: expected brdf, reflectance-factor or relative",
                ms.kind
            ),
        );
    }
    Ok(())
}

/// `[paint]`.
fn check_paint(ps: &PaintSection, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if ![
        "auto",
        "gaussian",
        "trowbridge-reitz",
        "pearson-vii",
        "table",
    ]
    .contains(&ps.family.as_str())
    {
        return bad(
            "paint.family",
            format!(
                "`{}`: expected auto, gaussian, trowbridge-reitz, pearson-vii or table",
                ps.family
            ),
        );
    }
    if let Some(c) = ps.coverage
        && !(0.0..=1.0).contains(&c)
    {
        return bad(
            "paint.coverage",
            format!("{c}: expected a fraction in [0, 1]"),
        );
    }
    if let Some([lo, hi]) = ps.region_deg
        && !(lo >= 0.0 && hi > lo && hi <= 180.0)
    {
        return bad(
            "paint.region_deg",
            format!("[{lo}, {hi}]: expected 0 <= LO < HI <= 180 degrees"),
        );
    }
    if let Some(t) = ps.max_theta_r_deg
        && !(t > 0.0 && t <= 90.0)
    {
        return bad(
            "paint.max_theta_r_deg",
            format!("{t}: expected (0, 90] degrees"),
        );
    }
    if let Some(v) = ps.min_value
        && !(v.is_finite() && v >= 0.0)
    {
        return bad(
            "paint.min_value",
            format!("{v}: expected a BRDF >= 0 (1/sr)"),
        );
    }
    Ok(())
}

/// `[stats]`.
fn check_stats(st: &StatsSection, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if !(st.bin_deg.is_finite() && (0.001..=45.0).contains(&st.bin_deg)) {
        return bad(
            "stats.bin_deg",
            format!("{}: expected [0.001, 45] degrees", st.bin_deg),
        );
    }
    if !(st.overlay_max_deg.is_finite() && st.overlay_max_deg > 0.0 && st.overlay_max_deg <= 90.0) {
        return bad(
            "stats.overlay_max_deg",
            format!("{}: expected (0, 90] degrees", st.overlay_max_deg),
        );
    }
    Ok(())
}

/// `[models]`; `has_measured`: whether the manifest has a `[measured]` table (the width fit needs one).
fn check_models(md: &ModelsSection, has_measured: bool, file: &str) -> Result<(), ManifestError> {
    let bad = |key: &str, msg: String| bad(file, key, msg);
    if let Some(t) = &md.theta_i_deg {
        if t.is_empty() {
            return bad("models.theta_i_deg", "empty list".into());
        }
        if let Some(x) = t
            .iter()
            .find(|x| !(x.is_finite() && (0.0..90.0).contains(*x)))
        {
            return bad("models.theta_i_deg", format!("{x}° is outside [0, 90)"));
        }
    }
    if let Some(a) = &md.theta_s_deg {
        let v = a
            .degrees("models.theta_s_deg")
            .map_err(|message| ManifestError {
                file: file.to_owned(),
                message: format!("key {message}"),
            })?;
        if let Some(x) = v.iter().find(|x| !(x.is_finite() && x.abs() < 90.0)) {
            return bad("models.theta_s_deg", format!("{x}° is outside (-90, 90)"));
        }
    }
    if !(md.aperture_deg.is_finite() && md.aperture_deg > 0.0 && md.aperture_deg <= 20.0) {
        return bad(
            "models.aperture_deg",
            format!(
                "{}: expected a half-angle in (0, 20] degrees",
                md.aperture_deg
            ),
        );
    }
    if let Err(e) = crate::checks::window(md.window) {
        return bad("models.window", e.to_string());
    }
    if let Err(e) = crate::checks::tile_um(md.tile_um) {
        return bad("models.tile_um", e.to_string());
    }
    if md.fit && !has_measured {
        return bad(
            "models.fit",
            "the width fit needs a measured curve: add [measured] or set fit = false".into(),
        );
    }
    Ok(())
}
