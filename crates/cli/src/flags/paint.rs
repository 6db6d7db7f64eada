//! A paint from flags (`model --paint`, `compare --paint`): coat, flakes and base of
//! physics.md §12 with the orientation flags, for trying a formulation without a fit.

use anyhow::{Context, bail};
use flakescatter::paint_model::{
    Channel, ChannelParams, CoatParams, FlakeMetal, PaintModel, PaintParams,
};
use flakescatter::stats::Orientation;

/// The paint flags.
#[derive(Debug, Clone, clap::Args)]
pub struct PaintFlags {
    /// A paint (clear coat, flakes, base; physics.md §12) built from these flags and the
    /// orientation flags, instead of the bare distribution model: columns
    /// `brdf_<channel>_per_sr` per --channels.
    #[arg(long)]
    pub paint: bool,
    /// --paint: channels, comma-separated (r, g, b, y or wavelengths like 550nm;
    /// default g).
    #[arg(long, value_name = "LIST", requires = "paint")]
    pub channels: Option<String>,
    /// --paint: the flakes' coverage, in [0, 1] (default 0.5).
    #[arg(
        long = "paint-coverage",
        value_name = "C",
        requires = "paint",
        allow_negative_numbers = true
    )]
    pub coverage: Option<f64>,
    /// --paint: flake reflectance scale per channel, in [0, 1] (one value, or one per
    /// channel; default 1).
    #[arg(
        long,
        value_name = "LIST",
        requires = "paint",
        allow_hyphen_values = true
    )]
    pub flake_scale: Option<String>,
    /// --paint: base albedo per channel, in [0, 1] (one value, or one per channel;
    /// default 0). `model` without --paint: one albedo of a Lambertian base under
    /// thin-film flakes (--flake-stack without --flake-core; physics.md §13), default 0,
    /// a black base.
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub base_albedo: Option<String>,
    /// --paint: GGX slope scale of the coat's surface, in [0, 2] (default 0: flat).
    #[arg(
        long,
        value_name = "A",
        requires = "paint",
        allow_negative_numbers = true
    )]
    pub coat_roughness: Option<f64>,
    /// --paint: haze fraction of the coat's surface, in [0, 1] (default 0).
    #[arg(
        long,
        value_name = "H",
        requires = "paint",
        allow_negative_numbers = true
    )]
    pub haze: Option<f64>,
    /// --paint: GGX slope scale of the haze, in (0, 2] (needed with --haze > 0).
    #[arg(
        long,
        value_name = "A",
        requires = "paint",
        allow_negative_numbers = true
    )]
    pub haze_roughness: Option<f64>,
}

/// The flake metal of a paint from the coating flags: `--flake-index N,K` if given,
/// else aluminium at each channel's wavelength (a paint's default; the bare models'
/// default is a perfect conductor).
pub fn flake_metal(optics: &super::OpticsArgs) -> anyhow::Result<FlakeMetal> {
    Ok(match optics.coating()?.flake {
        flakescatter::optics::flake::FlakeReflectance::Complex { n, k }
            if optics.flake_index.is_some() =>
        {
            FlakeMetal::Index { n, k }
        }
        _ => FlakeMetal::Aluminium,
    })
}

/// The flakes of a paint fit: interference flakes of `--flake-stack` (and
/// `--flake-core`), taken at each channel's wavelength, else [`flake_metal`].
pub fn paint_flakes(
    optics: &super::OpticsArgs,
    spectral: &super::SpectralArgs,
) -> anyhow::Result<FlakeMetal> {
    match spectral.stack_specs()? {
        Some((stack, core)) => Ok(FlakeMetal::stack(stack, core)),
        None => flake_metal(optics),
    }
}

/// `n` values for `n` channels from a list of one or `n` numbers (`flag` for messages).
fn per_channel(flag: &str, text: Option<&str>, n: usize, default: f64) -> anyhow::Result<Vec<f64>> {
    let Some(text) = text else {
        return Ok(vec![default; n]);
    };
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{flag} {text}: expected numbers separated by commas"))?;
    match v.len() {
        1 => Ok(vec![v[0]; n]),
        k if k == n => Ok(v),
        k => bail!("{flag} {text}: {k} values for {n} channels (give one, or one per channel)"),
    }
}

impl PaintFlags {
    /// Refuses `--base-albedo` without `--paint` in a command whose distribution model
    /// has no base (`compare`, `export`: a base under the flakes is `model`'s).
    pub fn refuse_base_without_paint(&self, command: &str) -> anyhow::Result<()> {
        if self.base_albedo.is_some() && !self.paint {
            bail!(
                "--base-albedo without --paint: {command} models a black base under the flakes (a base under thin-film flakes is `model --flake-stack SPEC --base-albedo RHO`)"
            );
        }
        Ok(())
    }

    /// The paint of the flags with `orientation`, a coat of index `n`, flakes of
    /// `metal`; checked (the model's own range checks name the value).
    pub fn model(
        &self,
        orientation: Orientation,
        n: f64,
        metal: FlakeMetal,
    ) -> anyhow::Result<PaintModel> {
        let names: Vec<&str> = self
            .channels
            .as_deref()
            .unwrap_or("g")
            .split(',')
            .map(str::trim)
            .collect();
        let channels = names
            .iter()
            .map(|c| Channel::parse(c).with_context(|| format!("--channels {c}")))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let scale = per_channel(
            "--flake-scale",
            self.flake_scale.as_deref(),
            channels.len(),
            1.0,
        )?;
        let albedo = per_channel(
            "--base-albedo",
            self.base_albedo.as_deref(),
            channels.len(),
            0.0,
        )?;
        let haze = self.haze.unwrap_or(0.0);
        let params = PaintParams {
            coat: CoatParams {
                n,
                roughness: self.coat_roughness.unwrap_or(0.0),
                haze,
                haze_roughness: self.haze_roughness.unwrap_or(0.0),
            },
            orientation,
            coverage: self.coverage.unwrap_or(0.5),
            flake_metal: metal,
            channels: channels
                .into_iter()
                .zip(scale.into_iter().zip(albedo))
                .map(|(channel, (flake_scale, base_albedo))| ChannelParams {
                    channel,
                    flake_scale,
                    base_albedo,
                    tint: 0.0,
                })
                .collect(),
        };
        PaintModel::new(params).context("--paint")
    }
}
