//! Segmentation overlays as PNG files: the map area exactly as the facade's
//! [`Overlay`] gives it (pixel for pixel), flake numbers, and a strip on the right
//! with the tilt colour bar in degrees and the legend of the other colours.

use flakescatter::overlay::{HATCH, NO_DATA, Overlay, tilt_colour};
use plotters::prelude::*;

use crate::output::Failure;
use crate::plot::{encode_rgb, register_fonts};

/// Width of the colour-bar strip, pixels.
pub const STRIP: u32 = 170;
/// Smallest image height, pixels (room for the colour bar and legend).
pub const MIN_HEIGHT: u32 = 360;

/// The overlay as PNG bytes: the map area at the top left (`o.width × o.height`), the
/// strip to its right; `name` names the file in errors and `title` heads the strip.
pub fn overlay_png(o: &Overlay, title: &str, name: &str) -> anyhow::Result<Vec<u8>> {
    register_fonts()?;
    let (w, h) = (o.width + STRIP, o.height.max(MIN_HEIGHT));
    let mut rgb = vec![255u8; w as usize * h as usize * 3];
    for y in 0..o.height as usize {
        let src = &o.rgb[y * o.width as usize * 3..(y + 1) * o.width as usize * 3];
        let at = y * w as usize * 3;
        rgb[at..at + src.len()].copy_from_slice(src);
    }
    let err = |e: &dyn std::fmt::Display| Failure(format!("drawing {name}: {e}"));
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        let font = ("sans-serif", 13).into_font();
        let small = ("sans-serif", 11).into_font();
        for l in &o.labels {
            let style = font
                .clone()
                .color(&BLACK)
                .pos(plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Center,
                    plotters::style::text_anchor::VPos::Center,
                ));
            root.draw(&Text::new(l.text.clone(), (l.x as i32, l.y as i32), style))
                .map_err(|e| err(&e))?;
        }
        let x0 = o.width as i32 + 14;
        root.draw(&Text::new(
            title.to_owned(),
            (x0, 8),
            small.clone().color(&BLACK),
        ))
        .map_err(|e| err(&e))?;
        root.draw(&Text::new(
            "tilt θn (degrees)".to_owned(),
            (x0, 26),
            font.clone().color(&BLACK),
        ))
        .map_err(|e| err(&e))?;
        // The bar: top = max tilt, bottom = 0, 200 pixels.
        let (top, len) = (48i32, 200i32);
        let max_deg = o.max_tilt.to_degrees();
        for k in 0..len {
            let t = 1.0 - f64::from(k) / f64::from(len - 1);
            let c = tilt_colour(t * o.max_tilt, o.max_tilt);
            root.draw(&Rectangle::new(
                [(x0, top + k), (x0 + 22, top + k + 1)],
                RGBColor(c[0], c[1], c[2]).filled(),
            ))
            .map_err(|e| err(&e))?;
        }
        let step = if max_deg > 40.0 { 10.0 } else { 5.0 };
        let mut d = 0.0;
        while d <= max_deg + 1e-9 {
            let y = top + ((1.0 - d / max_deg) * f64::from(len - 1)).round() as i32;
            root.draw(&PathElement::new(vec![(x0 + 22, y), (x0 + 28, y)], BLACK))
                .map_err(|e| err(&e))?;
            let text = if (d - max_deg).abs() < 1e-9 {
                format!("≥ {d:.0}")
            } else {
                format!("{d:.0}")
            };
            root.draw(&Text::new(
                text,
                (x0 + 32, y - 6),
                small.clone().color(&BLACK),
            ))
            .map_err(|e| err(&e))?;
            d += step;
        }
        // Legend.
        let mut y = top + len + 20;
        for (colour, text) in [
            (NO_DATA, "no data / below cutoff"),
            (HATCH, "valid, in no flake"),
            ([0, 0, 0], "flake outline"),
        ] {
            root.draw(&Rectangle::new(
                [(x0, y), (x0 + 14, y + 14)],
                RGBColor(colour[0], colour[1], colour[2]).filled(),
            ))
            .map_err(|e| err(&e))?;
            root.draw(&Text::new(
                text.to_owned(),
                (x0 + 20, y + 1),
                small.clone().color(&BLACK),
            ))
            .map_err(|e| err(&e))?;
            y += 20;
        }
        root.present().map_err(|e| err(&e))?;
    }
    encode_rgb(w, h, &rgb, name)
}
