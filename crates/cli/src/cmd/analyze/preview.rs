//! Rendered previews in `analyze` reports: the sample's paint (fitted, or predicted from
//! its maps; `flakescatter::analyze::PreviewModel`) tabulated as a MERL table and
//! rendered as a sphere by the Python package's `flakescatter.mitsuba` (Mitsuba 3), run
//! as `PYTHON -m flakescatter.mitsuba preview TABLE.binary OUT.png`. `PYTHON` is
//! `$FLAKESCATTER_PYTHON`, else `python3`. When that Python cannot import the package
//! and Mitsuba, the report says so instead of showing a picture, and the run goes on.
//!
//! A preview is kept in the report's `cache/preview.json` under a key of the model (its
//! parameters, bit for bit), the build, the renderer's versions and the render settings,
//! so that a rerun with nothing changed renders nothing.

use std::ffi::OsString;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, bail};
use flakescatter::analyze::PreviewModel;
use serde_json::{Value, json};

use crate::output::scratch::{Scratch, read_bytes};

/// Render settings of a report's preview (the sphere, pixels, samples per pixel, seed).
const RESOLUTION: u32 = 192;
const SPP: u32 = 32;
const SEED: u32 = 0;

/// A Python that can render, and what it reported about itself.
pub struct Renderer {
    python: OsString,
    /// `{"mitsuba": version, "variant": ...}` from `check`.
    identity: Value,
}

/// Whether previews can be rendered here, and if not why.
pub enum Availability {
    /// Ready.
    Ready(Renderer),
    /// Not here: the reason, for the report's note.
    Missing(String),
}

/// Looks for a Python with `flakescatter.mitsuba` and Mitsuba.
pub fn probe() -> Availability {
    let python = std::env::var_os("FLAKESCATTER_PYTHON").unwrap_or_else(|| "python3".into());
    let shown = python.to_string_lossy().into_owned();
    match Command::new(&python)
        .args(["-m", "flakescatter.mitsuba", "check"])
        .output()
    {
        Err(e) => Availability::Missing(format!("{shown} cannot be run ({e})")),
        Ok(o) if !o.status.success() => {
            let err = String::from_utf8_lossy(&o.stderr);
            let last = err
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("");
            Availability::Missing(format!("{shown}: {}", last.trim()))
        }
        Ok(o) => match serde_json::from_slice(&o.stdout) {
            Ok(identity) => Availability::Ready(Renderer { python, identity }),
            Err(_) => Availability::Missing(format!(
                "{shown} -m flakescatter.mitsuba check printed no version"
            )),
        },
    }
}

impl Renderer {
    /// The cache key of a preview of `model` (module docs).
    pub fn key(&self, model: &PreviewModel, build: &str) -> String {
        flakescatter::io::files::sha256_bytes(
            json!({
                "model": format!("{model:?}"),
                "build": build,
                "renderer": self.identity,
                "settings": [RESOLUTION, SPP, SEED],
            })
            .to_string()
            .as_bytes(),
        )
    }

    /// The renderer's versions, for the report.
    pub fn identity(&self) -> &Value {
        &self.identity
    }

    /// Renders `model` as a sphere: the PNG's bytes.
    pub fn preview(&self, model: &PreviewModel) -> anyhow::Result<Vec<u8>> {
        let table = model.table().context("tabulating the preview's BRDF")?;
        let scratch = Scratch::new()?;
        let merl = scratch.write("preview.binary", |w| {
            flakescatter::io::merl::write_merl(w, &table)
        })?;
        let png = scratch.path("preview.png");
        self.run(&[
            "preview".as_ref(),
            merl.as_os_str(),
            png.as_os_str(),
            "--resolution".as_ref(),
            RESOLUTION.to_string().as_ref(),
            "--spp".as_ref(),
            SPP.to_string().as_ref(),
            "--seed".as_ref(),
            SEED.to_string().as_ref(),
        ])?;
        scratch.read("preview.png")
    }

    /// The previews side by side (left to right in the order given): the PNG's bytes.
    pub fn montage(&self, pngs: &[Vec<u8>]) -> anyhow::Result<Vec<u8>> {
        let scratch = Scratch::new()?;
        let out = scratch.path("samples.png");
        let mut args: Vec<OsString> = vec!["montage".into(), out.into_os_string()];
        for (k, b) in pngs.iter().enumerate() {
            let p = scratch.write(&format!("{k}.png"), |w| w.write_all(b))?;
            args.push(p.into_os_string());
        }
        let refs: Vec<&std::ffi::OsStr> = args.iter().map(OsString::as_os_str).collect();
        self.run(&refs)?;
        scratch.read("samples.png")
    }

    fn run(&self, args: &[&std::ffi::OsStr]) -> anyhow::Result<()> {
        let o = Command::new(&self.python)
            .args(["-m", "flakescatter.mitsuba"])
            .args(args)
            .output()
            .with_context(|| format!("running {}", self.python.to_string_lossy()))?;
        if !o.status.success() {
            bail!(
                "{} -m flakescatter.mitsuba {}: {}",
                self.python.to_string_lossy(),
                args.first()
                    .map(|a| a.to_string_lossy())
                    .unwrap_or_default(),
                String::from_utf8_lossy(&o.stderr).trim()
            );
        }
        Ok(())
    }
}

/// The preview of a previous report at `dir` when its key is `key`.
pub fn cached(dir: &Path, key: &str) -> Option<Vec<u8>> {
    let text = flakescatter::io::files::read_text(dir.join("cache").join("preview.json")).ok()?;
    let v: Value = serde_json::from_str(&text).ok()?;
    (v["key"] == key)
        .then(|| read_bytes(&dir.join("preview.png")).ok())
        .flatten()
}

/// The cache file's text for `key`.
pub fn cache_text(key: &str, renderer: &Value) -> String {
    json!({"key": key, "renderer": renderer}).to_string() + "\n"
}
