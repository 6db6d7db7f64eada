//! Spectral flags (docs/cli.md "Spectral flags"): the wavelengths, the flakes' optical
//! constants, the clear coat's dispersion, the binder's absorption. The colorimetry and
//! the multi-angle geometry set are in `colour`.
//!
//! Wavelengths in nanometres here; the library gets nanometres.

use std::path::PathBuf;

use anyhow::{Context, bail};

use flakescatter::Instrument;
use flakescatter::io::spectral::{read_absorption, read_coat_index, read_complex_index};
use flakescatter::optics::absorption::FlakeDepth;
use flakescatter::optics::catalogue::{Catalogue, MaterialSpec};
use flakescatter::optics::dispersion::{Cauchy, CoatIndex, SpectralTable};
use flakescatter::optics::material::ComplexIndexTable;
use flakescatter::optics::stack_spec::StackSpec;
use flakescatter::spectral::{BinderAbsorption, FlakeSpectrum, MAX_WAVELENGTHS, SpectralCoating};
use serde_json::{Value, json};

use super::{InstrumentArgs, OpticsArgs};
use crate::output::Plan;
use crate::parse::{angles, check_range_in};

/// Default wavelengths of a colour computation, nm (CIE 015's 380–780 nm at 10 nm).
pub const DEFAULT_WAVELENGTHS: &str = "380:780:10";

/// Built-in optical constants of the flakes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FlakeMaterial {
    /// Aluminium, the built-in default table (Rakić 1995).
    Aluminium,
    /// Aluminium after Rakić, Appl. Opt. 34, 4755 (1995).
    Rakic,
    /// Aluminium after McPeak et al., ACS Photonics 2, 326 (2015).
    Mcpeak,
}

impl FlakeMaterial {
    fn table(self) -> &'static ComplexIndexTable {
        match self {
            Self::Aluminium | Self::Rakic => ComplexIndexTable::aluminium_rakic_1995(),
            Self::Mcpeak => ComplexIndexTable::aluminium_mcpeak_2015(),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Aluminium | Self::Rakic => "aluminium-rakic-1995",
            Self::Mcpeak => "aluminium-mcpeak-2015",
        }
    }
}

/// The spectral flags of `model`, `topo`, `compare` and `fit`.
#[derive(Debug, Clone, clap::Args)]
pub struct SpectralArgs {
    /// Wavelengths in nm, a list or an inclusive range `start:stop:step` (e.g.
    /// `380:780:10`): the model runs at each [default with --multi-angle and
    /// --measured-multiangle: 380:780:10].
    #[arg(long, value_name = "LIST")]
    pub wavelengths: Option<String>,
    /// Built-in optical constants of the flakes versus wavelength: aluminium (Rakić
    /// 1995), rakic, mcpeak (McPeak et al. 2015). Default: a perfect conductor, or
    /// --flake-index at every wavelength.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["flake_nk", "flake_index"])]
    pub flake_material: Option<FlakeMaterial>,
    /// Optical constants of the flakes from a CSV `wavelength_nm,n,k`.
    #[arg(long, value_name = "FILE", conflicts_with = "flake_index")]
    pub flake_nk: Option<PathBuf>,
    /// Interference flakes: each flake a thin-film stack, layers from the side light
    /// arrives on, `material:thickness_nm` separated by `/` (e.g.
    /// `TiO2:120/mica:400/TiO2:120`; materials as in `film`), in the clear coat's binder
    /// (physics.md §13). Runs at --wavelengths [default 380:780:10].
    #[arg(
        long,
        value_name = "SPEC",
        allow_hyphen_values = true,
        conflicts_with_all = ["flake_nk", "flake_index", "flake_material"]
    )]
    pub flake_stack: Option<String>,
    /// With --flake-stack: an opaque core under the layers (e.g. aluminium), a material
    /// name or `n+ki`. Default: none, a free flake with the binder below it.
    #[arg(
        long,
        value_name = "MATERIAL",
        allow_hyphen_values = true,
        requires = "flake_stack"
    )]
    pub flake_core: Option<String>,
    /// Clear-coat dispersion n(λ) = A + B/λ² + C/λ⁴ with λ in µm: `A,B` or `A,B,C`, B in
    /// µm², C in µm⁴ (e.g. 1.49,0.0045). Replaces --n.
    #[arg(long, value_name = "A,B[,C]", allow_hyphen_values = true, conflicts_with_all = ["coat_index", "n"])]
    pub coat_cauchy: Option<String>,
    /// Clear-coat index from a CSV `wavelength_nm,n` (linear between rows). Replaces --n.
    #[arg(long, value_name = "FILE", conflicts_with = "n")]
    pub coat_index: Option<PathBuf>,
    /// Absorption of the binder along each ray's path inside the film (a tinted or
    /// pigmented binder): a constant absorption coefficient in 1/µm (Napierian, for
    /// intensity, e.g. 0.05), or a CSV `wavelength_nm,alpha_per_um`. Needs
    /// --flake-depth-um or --film-um.
    #[arg(long, value_name = "ALPHA|FILE", allow_negative_numbers = true)]
    pub binder_absorption: Option<PathBuf>,
    /// With --binder-absorption: every flake at this depth below the top surface, µm
    /// (path d/cos θt + d/cos θ2).
    #[arg(
        long,
        value_name = "UM",
        allow_negative_numbers = true,
        requires = "binder_absorption",
        conflicts_with = "film_um"
    )]
    pub flake_depth_um: Option<f64>,
    /// With --binder-absorption: flakes spread uniformly over the depth of a film this
    /// thick, µm (the depth average of the path factor).
    #[arg(
        long,
        value_name = "UM",
        allow_negative_numbers = true,
        requires = "binder_absorption"
    )]
    pub film_um: Option<f64>,
}

impl SpectralArgs {
    /// Registers the files as inputs.
    pub fn inputs(&self, plan: &mut Plan) {
        for (flag, p) in [
            ("--flake-nk", &self.flake_nk),
            ("--coat-index", &self.coat_index),
            ("--binder-absorption", &self.binder_absorption),
        ] {
            if let Some(p) = p
                && !(flag == "--binder-absorption" && constant_alpha(p).is_some())
            {
                plan.input(flag, p);
            }
        }
    }

    /// Whether any spectral flag is given.
    pub fn any(&self) -> bool {
        self.wavelengths.is_some() || self.describes_a_spectrum()
    }

    /// Whether a spectral flag other than `--flake-stack`/`--flake-core` is given (the
    /// paint fit takes those two and takes the stack at each channel's wavelength).
    pub fn any_besides_stack(&self) -> bool {
        self.given()
            .into_iter()
            .any(|(flag, on)| on && flag != "--flake-stack")
    }

    /// `--flake-stack` and `--flake-core` as parsed specs (`None` without a stack).
    pub fn stack_specs(&self) -> anyhow::Result<Option<(StackSpec, Option<MaterialSpec>)>> {
        let Some(text) = self.flake_stack.as_deref() else {
            return Ok(None);
        };
        let catalogue = Catalogue::builtin();
        let stack = StackSpec::parse(text, &catalogue).context("--flake-stack")?;
        let core = self
            .flake_core
            .as_deref()
            .map(|c| catalogue.parse(c))
            .transpose()
            .context("--flake-core")?;
        Ok(Some((stack, core)))
    }

    /// Whether a flag makes the coating depend on wavelength.
    pub fn describes_a_spectrum(&self) -> bool {
        self.given()
            .into_iter()
            .any(|(flag, on)| on && flag != "--wavelengths")
    }

    /// The spectral flags in the order messages name them, and whether each is given.
    fn given(&self) -> [(&'static str, bool); 7] {
        [
            ("--wavelengths", self.wavelengths.is_some()),
            ("--flake-material", self.flake_material.is_some()),
            ("--flake-nk", self.flake_nk.is_some()),
            ("--flake-stack", self.flake_stack.is_some()),
            ("--coat-cauchy", self.coat_cauchy.is_some()),
            ("--coat-index", self.coat_index.is_some()),
            ("--binder-absorption", self.binder_absorption.is_some()),
        ]
    }

    /// The first spectral flag given, for messages.
    pub fn first_flag(&self) -> Option<&'static str> {
        self.given().into_iter().find_map(|(f, on)| on.then_some(f))
    }

    /// The `--wavelengths` list (or `default`), nm, checked: finite, > 0, strictly
    /// increasing, at most [`MAX_WAVELENGTHS`]. `None` when neither is given.
    pub fn wavelengths_nm(&self, default: Option<&str>) -> anyhow::Result<Option<Vec<f64>>> {
        let Some(text) = self.wavelengths.as_deref().or(default) else {
            return Ok(None);
        };
        parse_wavelengths(text).map(Some)
    }

    /// The text of the wavelength list used (for echoes).
    pub fn wavelengths_text<'a>(&'a self, default: &'a str) -> &'a str {
        self.wavelengths.as_deref().unwrap_or(default)
    }

    /// The checks of a curve run at every wavelength (`model` or `topo` with
    /// `--wavelengths`, no `--multi-angle`), in the order the user meets them: the
    /// wavelengths are required, `--plot` is refused, the spectral flags are valid, the
    /// instrument flags are, and the rows stay within [`super::MAX_ROWS`]. Returns the
    /// wavelengths (nm) and the instrument.
    pub fn curve_run(
        &self,
        instrument: &InstrumentArgs,
        plot: bool,
    ) -> anyhow::Result<(Vec<f64>, Instrument)> {
        // A stack has no single-wavelength meaning: its runs are spectral by default.
        let default = self.flake_stack.is_some().then_some(DEFAULT_WAVELENGTHS);
        let Some(wavelengths) = self.wavelengths_nm(default)? else {
            bail!(
                "{} describes the coating versus wavelength: give --wavelengths LIST (nm), e.g. 380:780:10, or --multi-angle",
                self.first_flag().unwrap_or("a spectral flag")
            );
        };
        if plot {
            bail!("--plot draws the curves of one wavelength; it does not apply to --wavelengths");
        }
        self.validate()?;
        let instrument = instrument.instrument()?;
        let rows = instrument.theta_i().len() as f64
            * instrument.detectors().len() as f64
            * wavelengths.len() as f64;
        if rows > super::MAX_ROWS as f64 {
            bail!(
                "--wavelengths with --theta-i and --theta-s: {rows:e} rows is more than the limit of {}",
                super::MAX_ROWS
            );
        }
        Ok((wavelengths, instrument))
    }

    /// `--flake-stack` (and `--flake-core`) as a flake spectrum, with its JSON echo.
    fn stack_flake(&self) -> anyhow::Result<(FlakeSpectrum, Value)> {
        let Some((stack, core)) = self.stack_specs()? else {
            bail!("--flake-stack is not given");
        };
        let echo = json!({
            "stack": stack.label(),
            "core": core.as_ref().map(MaterialSpec::label),
            "medium": "the clear coat's index on both sides (a free flake) unless a core is given",
        });
        Ok((FlakeSpectrum::Stack { stack, core }, echo))
    }

    /// `--base-albedo RHO` of `model` and `topo` (`text`), checked against its range and
    /// the flakes and readouts it applies to (`polarised`: a polarised readout was asked
    /// for); `None` when not given.
    pub fn base_albedo(&self, text: Option<&str>, polarised: bool) -> anyhow::Result<Option<f64>> {
        let Some(text) = text else {
            return Ok(None);
        };
        let rho = match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && (0.0..=1.0).contains(&v) => v,
            _ => bail!(
                "--base-albedo {text}: expected one albedo in [0, 1] for the base under the flakes (0 is a black base; a list per channel is for --paint)"
            ),
        };
        if self.flake_stack.is_none() || self.flake_core.is_some() {
            bail!(
                "--base-albedo: the base under the flakes only receives light that thin-film flakes transmit; give --flake-stack SPEC without --flake-core (metal flakes and a core transmit nothing)"
            );
        }
        if polarised {
            bail!(
                "--base-albedo: the base under the flakes is modelled for unpolarised light; it does not apply to --polarization/--incident/--analyzer"
            );
        }
        if self.binder_absorption.is_some() {
            bail!(
                "--base-albedo with --binder-absorption: the base's light crosses the whole film, which the flakes' depth does not describe; the base is modelled for a clear binder (physics.md §13)"
            );
        }
        Ok(Some(rho))
    }

    /// Checks the flags that need no file.
    pub fn validate(&self) -> anyhow::Result<()> {
        if self.flake_stack.is_some() {
            self.stack_flake()?;
        }
        if let Some(c) = &self.coat_cauchy {
            cauchy(c)?;
        }
        if self.binder_absorption.is_some()
            && self.flake_depth_um.is_none()
            && self.film_um.is_none()
        {
            bail!(
                "--binder-absorption needs where the flakes are: --flake-depth-um D (all at depth D) or --film-um T (spread over a film T thick)"
            );
        }
        for (flag, v, zero_ok) in [
            ("--flake-depth-um", self.flake_depth_um, true),
            ("--film-um", self.film_um, false),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0)))
            {
                bail!(
                    "{flag} {v}: expected a finite thickness {} µm",
                    if zero_ok { ">= 0" } else { "> 0" }
                );
            }
        }
        Ok(())
    }

    /// The coating the flags describe with the coat and flake flags of `optics`
    /// (`--n`, `--flake-index` at every wavelength when no spectral flag replaces them),
    /// reading the files through `io`. Returns the JSON echo too.
    pub fn coating(&self, optics: &OpticsArgs) -> anyhow::Result<(SpectralCoating, Value)> {
        self.validate()?;
        let base = optics.coating()?;
        let (coat, coat_echo) = match (&self.coat_cauchy, &self.coat_index) {
            (Some(c), _) => {
                let k = cauchy(c)?;
                (
                    CoatIndex::Cauchy(k),
                    json!({"cauchy": {"a": k.a(), "b_um2": k.b_um2(), "c_um4": k.c_um4()}}),
                )
            }
            (None, Some(path)) => {
                let f = read_coat_index(path)
                    .with_context(|| format!("reading --coat-index {}", path.display()))?;
                let t = SpectralTable::new(f.wavelengths_nm, f.values, "index", 1.0)
                    .with_context(|| format!("--coat-index {}", path.display()))?;
                (
                    CoatIndex::Table(t),
                    json!({"file": path.display().to_string()}),
                )
            }
            (None, None) => (CoatIndex::Constant(base.n), json!({"n": base.n})),
        };
        let (flake, flake_echo) = match (self.flake_material, &self.flake_nk) {
            _ if self.flake_stack.is_some() => self.stack_flake()?,
            (Some(m), _) => (FlakeSpectrum::Table(m.table().clone()), json!(m.name())),
            (None, Some(path)) => {
                let f = read_complex_index(path)
                    .with_context(|| format!("reading --flake-nk {}", path.display()))?;
                let t = ComplexIndexTable::new(f.wavelengths_nm, f.n, f.k)
                    .with_context(|| format!("--flake-nk {}", path.display()))?;
                (
                    FlakeSpectrum::Table(t),
                    json!({"file": path.display().to_string()}),
                )
            }
            (None, None) => (
                FlakeSpectrum::Fixed(base.flake),
                json!(
                    optics
                        .flake_index
                        .clone()
                        .unwrap_or_else(|| "perfect-conductor".into())
                ),
            ),
        };
        let (binder, binder_echo) = match &self.binder_absorption {
            None => (None, Value::Null),
            Some(path) => {
                let (t, source) = binder_table(path)?;
                let (depth, echo) = match (self.flake_depth_um, self.film_um) {
                    (Some(d), _) => (FlakeDepth::At { depth_um: d }, json!({"flake_depth_um": d})),
                    (None, Some(t)) => (
                        FlakeDepth::UniformInFilm { film_um: t },
                        json!({"film_um": t, "depths": "uniform over the film"}),
                    ),
                    (None, None) => {
                        bail!("--binder-absorption needs --flake-depth-um D or --film-um T")
                    }
                };
                let mut e = source;
                e["alpha"] = json!("Napierian, 1/um");
                e["depth"] = echo;
                (
                    Some(BinderAbsorption {
                        alpha_per_um: t,
                        depth,
                    }),
                    e,
                )
            }
        };
        Ok((
            SpectralCoating {
                coat,
                flake,
                binder,
            },
            json!({"clear_coat": coat_echo, "flake": flake_echo, "binder_absorption": binder_echo}),
        ))
    }
}

/// `--wavelengths LIST|START:STOP:STEP`, nm, checked: finite, > 0, strictly
/// increasing, at most [`MAX_WAVELENGTHS`]; every error names the flag.
pub fn parse_wavelengths(text: &str) -> anyhow::Result<Vec<f64>> {
    let w = angles("--wavelengths", text)?;
    if w.len() > MAX_WAVELENGTHS {
        bail!(
            "--wavelengths {text}: {} wavelengths is more than the limit of {MAX_WAVELENGTHS}",
            w.len()
        );
    }
    check_range_in(
        "--wavelengths",
        &w,
        (0.0, f64::INFINITY),
        (true, true),
        (" nm", "nanometres"),
    )?;
    if let Some(p) = w.windows(2).find(|p| p[1] <= p[0]) {
        bail!(
            "--wavelengths {text}: {} nm does not follow {} nm; give strictly increasing wavelengths",
            p[1],
            p[0]
        );
    }
    Ok(w)
}

/// `--binder-absorption` as a number (a constant coefficient), if it is one.
pub fn constant_alpha(p: &std::path::Path) -> Option<f64> {
    p.to_str().and_then(|s| s.trim().parse::<f64>().ok())
}

/// `--binder-absorption ALPHA|FILE` as a table, with its JSON echo (`{"file": …}` or
/// `{"constant_per_um": …}`).
pub fn binder_table(path: &std::path::Path) -> anyhow::Result<(SpectralTable, Value)> {
    if let Some(a) = constant_alpha(path) {
        let t = SpectralTable::constant(a, "absorption coefficient", 0.0).map_err(|_| {
            anyhow::anyhow!(
                "--binder-absorption {a}: expected a finite absorption coefficient >= 0 (1/µm) or a CSV file"
            )
        })?;
        return Ok((t, json!({"constant_per_um": a})));
    }
    let f = read_absorption(path)
        .with_context(|| format!("reading --binder-absorption {}", path.display()))?;
    let t = SpectralTable::new(f.wavelengths_nm, f.values, "absorption coefficient", 0.0)
        .with_context(|| format!("--binder-absorption {}", path.display()))?;
    Ok((t, json!({"file": path.display().to_string()})))
}

/// `A,B[,C]` of `--coat-cauchy`.
fn cauchy(text: &str) -> anyhow::Result<Cauchy> {
    let parsed: Option<Vec<f64>> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect();
    let (a, b, c) = match parsed.as_deref() {
        Some([a, b]) => (*a, *b, 0.0),
        Some([a, b, c]) => (*a, *b, *c),
        _ => bail!(
            "--coat-cauchy {text}: expected two or three finite numbers `A,B[,C]` (B in µm², C in µm⁴; e.g. 1.49,0.0045)"
        ),
    };
    if a < 1.0 {
        bail!("--coat-cauchy {text}: A = {a} is below 1; a clear coat has n >= 1");
    }
    Ok(Cauchy::new(a, b, c)?)
}
