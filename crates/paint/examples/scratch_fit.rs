//! scratch: fit a paint CSV
use flakescatter_paint::Channel;
use flakescatter_paint::fit::{Family, FitOptions, Measurement, Observation, fit_paint};
fn main() {
    let path = std::env::args().nth(1).unwrap();
    let fam = std::env::args().nth(2).unwrap_or("all".into());
    let mut rdr = csv::Reader::from_path(&path).unwrap();
    let mut rows = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let r = rec.unwrap();
        let v: Vec<f64> = r.iter().map(|x| x.parse().unwrap()).collect();
        rows.push(Observation {
            theta_i: v[0].to_radians(),
            theta_r: v[1].to_radians(),
            phi_r: v[2].to_radians(),
            values: v[3..6].to_vec(),
            uncertainties: vec![None; 3],
            line: i as u64 + 2,
        });
    }
    let m = Measurement {
        file: path.clone(),
        channels: ["r", "g", "b"]
            .iter()
            .map(|c| Channel::parse(c).unwrap())
            .collect(),
        rows,
    };
    let mut opts = FitOptions::new();
    opts.selection.max_theta_r = 80f64.to_radians();
    opts.selection.min_value = 1e-3;
    opts.fit_n = std::env::var("FITN").is_ok();
    if let Ok(n) = std::env::var("N") {
        opts.n = n.parse().unwrap();
    }
    opts.families = match fam.as_str() {
        "all" => Family::all(),
        "gaussian" => vec![Family::Gaussian],
        "tr" => vec![Family::TrowbridgeReitz],
        "pearson" => vec![Family::PearsonVii],
        _ => vec![Family::LogLinear {
            knots: Family::default_knots(),
        }],
    };
    let t = std::time::Instant::now();
    let f = fit_paint(&m, &opts).unwrap();
    println!(
        "{} in {:?}, {} iterations, family {}",
        path,
        t.elapsed(),
        f.iterations,
        f.family.name()
    );
    for c in &f.candidates {
        println!(
            "  {:18} chi2 {:.3} k {} aic {:.1} bic {:.1}",
            c.family.name(),
            c.evidence.chi2,
            c.evidence.parameters,
            c.evidence.aic,
            c.evidence.bic
        );
    }
    let mut worst = 0.0f64;
    for g in &f.groups {
        let tgt = match (g.theta_i, g.region) {
            (None, flakescatter_paint::fit::Region::All) => Some(0.1),
            (
                Some(t),
                flakescatter_paint::fit::Region::Near | flakescatter_paint::fit::Region::Far,
            ) => Some(if t.to_degrees() > 70.0 {
                0.2
            } else if g.region == flakescatter_paint::fit::Region::Near {
                0.06
            } else {
                0.12
            }),
            _ => None,
        };
        if let Some(t) = tgt {
            worst = worst.max(g.rms_log10 / t);
        }
        println!(
            "  {:?} {:>8} n {:4} rms {:.3} mean {:+.3} {}",
            g.theta_i.map(f64::to_degrees),
            g.region.name(),
            g.points,
            g.rms_log10,
            g.mean_log10,
            tgt.map_or(String::new(), |t| format!("target {t}"))
        );
    }
    println!("  worst ratio {worst:.2}");
    for e in &f.physical {
        println!(
            "  {:24} {:.5} ± {:.5} [{:.5}, {:.5}]",
            e.name, e.value, e.std, e.lo95, e.hi95
        );
    }
    println!("  coverage {:?}", f.coverage);
    for w in &f.warnings {
        println!("  warning: {w}");
    }
    if let Ok(out) = std::env::var("DUMP") {
        let mut w = String::from("theta_i,theta_r,phi_r,channel,measured,model\n");
        for (p, v) in f.points.iter().zip(&f.model) {
            let o = &m.rows[p.row];
            w += &format!(
                "{},{},{},{},{},{}\n",
                o.theta_i.to_degrees().round(),
                o.theta_r.to_degrees().round(),
                o.phi_r.to_degrees().round(),
                p.channel,
                p.value,
                v
            );
        }
        std::fs::write(out, w).unwrap();
    }
}
