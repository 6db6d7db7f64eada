//! Named materials for thin-film layers, substrates and flakes: the built-in tables of
//! optical constants (`data/`, sources and licences in `data/README.md`), constants
//! `n + ki`, and user tables added by name.
//!
//! Conventions: as [`crate::material`] — wavelengths in vacuum, nm; `N = n + i k`,
//! `k ≥ 0`, relative to vacuum; linear interpolation between rows, no extrapolation.
//!
//! Built-in names (case-insensitive, aliases after the first):
//!
//! | name | material, source |
//! | --- | --- |
//! | `TiO2`, `rutile` | TiO2 rutile, ordinary ray, Devore 1951 (380–900 nm; below 430 nm the formula is extrapolated) |
//! | `anatase`, `TiO2-anatase` | TiO2 anatase, Jolivet et al. 2023 (ALD film, 299–827 nm) |
//! | `Fe2O3`, `hematite` | α-Fe2O3, ordinary ray, Querry 1985 (300–900 nm) |
//! | `SiO2`, `silica` | fused silica, Malitson 1965 (300–900 nm) |
//! | `Al2O3`, `alumina`, `sapphire` | sapphire, ordinary ray, Malitson 1962 (300–900 nm) |
//! | `mica`, `muscovite` | muscovite, in-plane index 1.600, no dispersion (Handbook of Mineralogy) |
//! | `aluminium`, `aluminum`, `Al` | Rakić 1995 (310–886 nm), as `--flake-material aluminium` |
//! | `Cr`, `chromium` | Johnson & Christy 1974 (292–984 nm) |
//! | `Ag`, `silver` | Johnson & Christy 1972 (292–984 nm) |
//!
//! # Example
//! ```
//! use flakescatter_optics::catalogue::{Catalogue, MaterialSpec};
//!
//! let cat = Catalogue::builtin();
//! let tio2 = cat.parse("TiO2").unwrap();
//! let n = tio2.index_at(550.0).unwrap();
//! assert!((n.re - 2.648).abs() < 1e-3 && n.im == 0.0);
//! let glass = cat.parse("1.52+0.001i").unwrap();
//! assert_eq!(glass, MaterialSpec::Constant(flakescatter_optics::nalgebra::Complex::new(1.52, 0.001)));
//! ```

use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

use nalgebra::Complex;

use crate::material::{ComplexIndexTable, MaterialError, parse_embedded};

/// A built-in table: canonical name, aliases, file name in `data/`, contents.
struct Builtin {
    name: &'static str,
    aliases: &'static [&'static str],
    file: &'static str,
    text: &'static str,
}

const BUILTINS: [Builtin; 9] = [
    Builtin {
        name: "TiO2",
        aliases: &["rutile"],
        file: "tio2_rutile.csv",
        text: include_str!("../data/tio2_rutile.csv"),
    },
    Builtin {
        name: "anatase",
        aliases: &["TiO2-anatase"],
        file: "tio2_anatase.csv",
        text: include_str!("../data/tio2_anatase.csv"),
    },
    Builtin {
        name: "Fe2O3",
        aliases: &["hematite"],
        file: "fe2o3.csv",
        text: include_str!("../data/fe2o3.csv"),
    },
    Builtin {
        name: "SiO2",
        aliases: &["silica"],
        file: "sio2.csv",
        text: include_str!("../data/sio2.csv"),
    },
    Builtin {
        name: "Al2O3",
        aliases: &["alumina", "sapphire"],
        file: "al2o3.csv",
        text: include_str!("../data/al2o3.csv"),
    },
    Builtin {
        name: "mica",
        aliases: &["muscovite"],
        file: "mica_muscovite.csv",
        text: include_str!("../data/mica_muscovite.csv"),
    },
    Builtin {
        name: "aluminium",
        aliases: &["aluminum", "Al"],
        file: "aluminium_rakic1995.csv",
        text: include_str!("../data/aluminium_rakic1995.csv"),
    },
    Builtin {
        name: "Cr",
        aliases: &["chromium"],
        file: "chromium.csv",
        text: include_str!("../data/chromium.csv"),
    },
    Builtin {
        name: "Ag",
        aliases: &["silver"],
        file: "silver.csv",
        text: include_str!("../data/silver.csv"),
    },
];

/// The embedded layer-material tables, byte for byte: `(file name, contents)`.
#[must_use]
pub fn embedded_files() -> Vec<(&'static str, &'static str)> {
    BUILTINS.iter().map(|b| (b.file, b.text)).collect()
}

/// The parsed built-in tables, in the order of [`BUILTINS`].
fn builtin_tables() -> &'static [Arc<ComplexIndexTable>] {
    static T: OnceLock<Vec<Arc<ComplexIndexTable>>> = OnceLock::new();
    T.get_or_init(|| {
        BUILTINS
            .iter()
            .map(|b| Arc::new(parse_embedded(b.text)))
            .collect()
    })
}

/// Errors from naming a material or looking up its index.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CatalogueError {
    /// Neither a known name nor a number `n`, `n+ki`.
    #[error("unknown material {name:?}: expected one of {known}, or an index such as 2.6+0.01i")]
    Unknown {
        /// The text given.
        name: String,
        /// The names known, comma-separated.
        known: String,
    },
    /// A constant index that does not parse or is not valid.
    #[error("index {text:?} is not valid: expected n or n+ki with finite n > 0 and k >= 0")]
    BadIndex {
        /// The text given.
        text: String,
    },
    /// A user table with an empty name or a name that is a number.
    #[error("material name {0:?} is not valid: expected a name that is not empty and not a number")]
    BadName(String),
    /// A lookup outside a table's wavelengths.
    #[error("material {name}: {source}")]
    Table {
        /// The material's name.
        name: String,
        /// What the table said.
        #[source]
        source: MaterialError,
    },
}

/// A material: a table of `n + ik` versus wavelength, or a constant index.
#[derive(Debug, Clone, PartialEq)]
pub enum MaterialSpec {
    /// A named table (built-in or the user's).
    Table {
        /// The name it goes by (the canonical built-in name, or the user's).
        name: String,
        /// Its optical constants.
        table: Arc<ComplexIndexTable>,
    },
    /// The same complex index at every wavelength.
    Constant(Complex<f64>),
}

impl MaterialSpec {
    /// `n + ik` at `wavelength_nm`.
    ///
    /// # Errors
    /// [`CatalogueError::Table`] outside a table's range.
    pub fn index_at(&self, wavelength_nm: f64) -> Result<Complex<f64>, CatalogueError> {
        match self {
            Self::Constant(c) => Ok(*c),
            Self::Table { name, table } => table
                .index_at(wavelength_nm)
                .map(|(n, k)| Complex::new(n, k))
                .map_err(|source| CatalogueError::Table {
                    name: name.clone(),
                    source,
                }),
        }
    }

    /// A short name for outputs: the table's name, or `n+ki`.
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            Self::Table { name, .. } => name.clone(),
            Self::Constant(c) => format!("{}+{}i", c.re, c.im),
        }
    }

    /// The wavelengths where it has a value, nm (`(0, ∞)` for a constant).
    #[must_use]
    pub fn range_nm(&self) -> (f64, f64) {
        match self {
            Self::Constant(_) => (0.0, f64::INFINITY),
            Self::Table { table, .. } => table.range_nm(),
        }
    }
}

/// The names a spec may use: the built-in tables and any the user adds.
#[derive(Debug, Clone, Default)]
pub struct Catalogue {
    user: BTreeMap<String, Arc<ComplexIndexTable>>,
}

impl Catalogue {
    /// The built-in materials only.
    #[must_use]
    pub fn builtin() -> Self {
        Self::default()
    }

    /// Add (or replace) a user table under `name` (case-insensitive; it shadows a
    /// built-in of the same name).
    ///
    /// # Errors
    /// [`CatalogueError::BadName`] for an empty name or one that reads as a number.
    pub fn add(&mut self, name: &str, table: ComplexIndexTable) -> Result<(), CatalogueError> {
        let name = name.trim();
        if name.is_empty() || parse_constant(name).is_some() || name.contains([':', '/']) {
            return Err(CatalogueError::BadName(name.to_string()));
        }
        self.user.insert(name.to_lowercase(), Arc::new(table));
        Ok(())
    }

    /// The canonical names known, comma-separated (built-ins, then the user's).
    #[must_use]
    pub fn known(&self) -> String {
        let mut v: Vec<String> = BUILTINS.iter().map(|b| b.name.to_string()).collect();
        v.extend(self.user.keys().cloned());
        v.join(", ")
    }

    /// A material from its name or a constant index `n` / `n+ki` / `n-0i`.
    ///
    /// # Errors
    /// [`CatalogueError::Unknown`] or [`CatalogueError::BadIndex`].
    pub fn parse(&self, text: &str) -> Result<MaterialSpec, CatalogueError> {
        let t = text.trim();
        let lower = t.to_lowercase();
        if let Some(table) = self.user.get(&lower) {
            return Ok(MaterialSpec::Table {
                name: t.to_string(),
                table: table.clone(),
            });
        }
        for (b, table) in BUILTINS.iter().zip(builtin_tables()) {
            if b.name.to_lowercase() == lower || b.aliases.iter().any(|a| a.to_lowercase() == lower)
            {
                return Ok(MaterialSpec::Table {
                    name: b.name.to_string(),
                    table: table.clone(),
                });
            }
        }
        let looks_numeric =
            t.starts_with(|c: char| c.is_ascii_digit() || c == '.' || c == '-' || c == '+');
        match parse_constant(t) {
            Some(c) if c.re.is_finite() && c.im.is_finite() && c.re > 0.0 && c.im >= 0.0 => {
                Ok(MaterialSpec::Constant(c))
            }
            Some(_) => Err(CatalogueError::BadIndex { text: t.into() }),
            None if looks_numeric => Err(CatalogueError::BadIndex { text: t.into() }),
            None => Err(CatalogueError::Unknown {
                name: t.into(),
                known: self.known(),
            }),
        }
    }
}

/// `n`, `n+ki`, `n-ki`, `n+k*i`, `n+kj` as a complex number (no validation of signs).
fn parse_constant(text: &str) -> Option<Complex<f64>> {
    let t: String = text.chars().filter(|c| !c.is_whitespace()).collect();
    if let Ok(re) = t.parse::<f64>() {
        return Some(Complex::new(re, 0.0));
    }
    let body = t.strip_suffix(['i', 'j'])?;
    let body = body.strip_suffix('*').unwrap_or(body);
    // The sign between the parts: the last + or − that does not follow an exponent 'e'.
    let bytes = body.as_bytes();
    let split = (1..bytes.len()).rev().find(|&i| {
        (bytes[i] == b'+' || bytes[i] == b'-') && !matches!(bytes[i - 1], b'e' | b'E')
    })?;
    let re: f64 = body[..split].parse().ok()?;
    let im_text = &body[split..];
    let im: f64 = if im_text == "+" || im_text == "-" {
        return None;
    } else {
        im_text.parse().ok()?
    };
    Some(Complex::new(re, im))
}
