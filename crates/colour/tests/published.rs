//! The colorimetry against published values: the CIE's own checksums and validation
//! sums of its data files, the defining formula of illuminant A against CIE 015's
//! table, white points printed in ASTM E308 and CIE 015:2018, closed forms for neutral
//! spectra, and the 34 CIEDE2000 test pairs of Sharma, Wu and Dalal (2005).

use flakescatter_colour::tables::{self, EMBEDDED_FILES, illuminant_a};
use flakescatter_colour::{
    Cie94, Ends, Illuminant, Integration, Lab, Observer, TristimulusWeights, delta_e_94,
    delta_e_2000, delta_e_ab,
};
use md5::{Digest, Md5};

const OBSERVERS: [Observer; 2] = [Observer::Cie1931TwoDegree, Observer::Cie1964TenDegree];
const ILLUMINANTS: [Illuminant; 3] = [Illuminant::D65, Illuminant::D50, Illuminant::A];

fn grid(a: f64, b: f64, s: f64) -> Vec<f64> {
    let n = ((b - a) / s).round() as usize;
    (0..=n).map(|i| a + s * i as f64).collect()
}

#[test]
fn embedded_cie_files_are_the_published_ones() {
    // MD5 checksums from the CIE's metadata records (DataCite JSON) of each dataset.
    let published = [
        ("CIE_xyz_1931_2deg.csv", "17cca777db64b17170f06f67ce9d3ab7"),
        ("CIE_xyz_1964_10deg.csv", "6140e032f9326d88c5a0959b29b4d8f3"),
        ("CIE_std_illum_D65.csv", "03d4eb9b837c60671627c946fb534deb"),
        ("CIE_std_illum_D50.csv", "e72757c3078b58e78ba63051be4b27b0"),
    ];
    for ((name, text), (want_name, want)) in EMBEDDED_FILES.iter().zip(published) {
        assert_eq!(*name, want_name);
        let digest = Md5::digest(text.as_bytes());
        let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
        assert_eq!(hex, want, "{name}");
    }
}

#[test]
fn parsed_tables_reproduce_the_cie_validation_values() {
    // "sumOfColumns" and "sampleRow" from the CIE metadata. The observer files cover
    // exactly 360–830 nm, so the column sums of the parsed tables must equal them (the
    // 10° z̄ sum skips the empty entries above 559 nm, which we read as 0).
    let sums = [
        (
            Observer::Cie1931TwoDegree,
            [106.865469489595, 106.8569171011719, 106.892251278636],
        ),
        (
            Observer::Cie1964TenDegree,
            [116.648519508908, 116.661877102312, 116.673980514647],
        ),
    ];
    for (obs, want) in sums {
        let cmf = obs.colour_matching_functions();
        for (c, w) in want.iter().enumerate() {
            let s: f64 = cmf.iter().map(|r| r[c]).sum();
            assert!((s - w).abs() < 1e-9, "{obs:?} column {c}: {s} vs {w}");
        }
    }
    let row = |nm: usize| nm - 360;
    assert_eq!(
        Observer::Cie1931TwoDegree.colour_matching_functions()[row(479)],
        [0.1042979, 0.1334528, 0.8566193]
    );
    assert_eq!(
        Observer::Cie1964TenDegree.colour_matching_functions()[row(479)],
        [0.089388, 0.245997, 0.81828]
    );
    assert_eq!(
        Observer::Cie1964TenDegree.colour_matching_functions()[row(579)],
        [1.00191, 0.877986, 0.0]
    );
    assert_eq!(Illuminant::D65.relative_spd()[row(419)], 93.2372);
    assert_eq!(Illuminant::D50.relative_spd()[row(419)], 59.6817);
    // The illuminant sums run over the whole file, 300–830 nm.
    for (name, want) in [
        ("CIE_std_illum_D65.csv", 40852.204),
        ("CIE_std_illum_D50.csv", 39484.93457),
    ] {
        let text = EMBEDDED_FILES.iter().find(|f| f.0 == name).unwrap().1;
        let s: f64 = text
            .lines()
            .map(|l| l.split(',').nth(1).unwrap().trim().parse::<f64>().unwrap())
            .sum();
        assert!((s - want).abs() < 1e-6, "{name}: {s}");
    }
    assert_eq!(Illuminant::D65.relative_spd()[row(560)], 100.0);
    assert_eq!(Illuminant::D50.relative_spd()[row(560)], 100.0);
}

#[test]
fn illuminant_a_formula_reproduces_the_cie_table() {
    // CIE 015:2018 Table 5 (as tabulated in colour-science 0.4.7's SDS_ILLUMINANTS["A"])
    // and the CIE 1 nm table's 830 nm entry: six significant figures.
    for (nm, want) in [
        (300.0, 0.930483),
        (360.0, 6.14462),
        (400.0, 14.708),
        (460.0, 37.8121),
        (560.0, 100.0),
        (700.0, 198.261),
        (780.0, 241.675),
        (830.0, 261.602),
    ] {
        let got = illuminant_a(nm);
        assert!(
            (got - want).abs() <= 5e-6 * want,
            "{nm} nm: {got} vs {want}"
        );
    }
    assert_eq!(Illuminant::A.relative_spd()[200], illuminant_a(560.0));
}

#[test]
fn one_nm_white_points_match_astm_e308() {
    // ASTM E308 white points (3 decimals; sums of its tables' rounded weights, hence
    // ±1e-3) for a 1 nm perfect reflector, 360–830 nm. (E308's D50 values, 96.422 and
    // 82.521, belong to a D50 at 1 nm made differently from the CIE's 2022 1 nm table,
    // which gives 96.424 and 82.513; D50 is checked against CIE 015 below.)
    let wl = grid(360.0, 830.0, 1.0);
    for (ill, obs, x, z) in [
        (Illuminant::D65, Observer::Cie1931TwoDegree, 95.047, 108.883),
        (Illuminant::D65, Observer::Cie1964TenDegree, 94.811, 107.304),
        (Illuminant::A, Observer::Cie1931TwoDegree, 109.850, 35.585),
        (Illuminant::A, Observer::Cie1964TenDegree, 111.144, 35.200),
    ] {
        let w = TristimulusWeights::new(&wl, ill, obs)
            .unwrap()
            .white_point();
        assert!(
            (w.x - x).abs() <= 1e-3 && (w.z - z).abs() <= 1e-3,
            "{ill:?}/{obs:?}: {w:?}"
        );
        assert!((w.y - 100.0).abs() < 1e-12);
    }
}

#[test]
fn five_nm_white_points_match_cie_015() {
    // CIE 015:2018's tristimulus values of the illuminants (2 decimals) are sums at 5 nm
    // over 380–780 nm: our 5 nm summation with the ends truncated reproduces all six to
    // their rounding (±0.005).
    let wl = grid(380.0, 780.0, 5.0);
    for (ill, obs, x, z) in [
        (Illuminant::D65, Observer::Cie1931TwoDegree, 95.04, 108.88),
        (Illuminant::D65, Observer::Cie1964TenDegree, 94.81, 107.32),
        (Illuminant::D50, Observer::Cie1931TwoDegree, 96.42, 82.51),
        (Illuminant::D50, Observer::Cie1964TenDegree, 96.72, 81.43),
        (Illuminant::A, Observer::Cie1931TwoDegree, 109.85, 35.58),
        (Illuminant::A, Observer::Cie1964TenDegree, 111.14, 35.20),
    ] {
        let weights = TristimulusWeights::with_ends(&wl, ill, obs, Ends::Truncate).unwrap();
        assert_eq!(weights.integration(), Integration::Summation);
        let w = weights.white_point();
        assert!(
            (w.x - x).abs() <= 0.005 && (w.z - z).abs() <= 0.005,
            "{ill:?}/{obs:?}: {w:?}"
        );
    }
}

#[test]
fn perfect_and_constant_reflectors_are_neutral() {
    // R = 1: X/Xn = Y/Yn = Z/Zn = 1 exactly, so L* = 100, a* = b* = 0 exactly. R = c:
    // a* = b* = 0 and L* = 116 c^(1/3) − 16 (c > (6/29)³) or 116 (c·841/108 + 4/29) − 16.
    let samplings = [
        grid(360.0, 830.0, 1.0),
        grid(380.0, 780.0, 5.0),
        grid(400.0, 700.0, 10.0),
        grid(400.0, 700.0, 20.0),
        grid(383.3, 721.7, 7.3), // off-grid: Lagrange weights
    ];
    for wl in &samplings {
        for ill in ILLUMINANTS {
            for obs in OBSERVERS {
                for ends in [Ends::Extend, Ends::Truncate] {
                    let w = TristimulusWeights::with_ends(wl, ill, obs, ends).unwrap();
                    let white = w.lab(&vec![1.0; wl.len()]).unwrap();
                    assert_eq!(
                        (white.l, white.a, white.b),
                        (100.0, 0.0, 0.0),
                        "{ill:?}/{obs:?}"
                    );
                    for c in [0.005, 0.18, 0.5, 1.7] {
                        let lab = w.lab(&vec![c; wl.len()]).unwrap();
                        let want = if c > (6.0f64 / 29.0).powi(3) {
                            116.0 * f64::cbrt(c) - 16.0
                        } else {
                            116.0 * (c * 841.0 / 108.0 + 4.0 / 29.0) - 16.0
                        };
                        assert!((lab.l - want).abs() < 1e-10, "c = {c}: {lab:?}");
                        assert!(
                            lab.a.abs() < 1e-10 && lab.b.abs() < 1e-10,
                            "c = {c}: {lab:?}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn ciede2000_reproduces_sharma_wu_dalal_2005() {
    // Table 1 of Sharma, Wu & Dalal, Color Res. Appl. 30 (2005) 21–30: all 34 pairs to
    // 1e-4, in both orders (the formula is symmetric). The same file carries ΔE*94 and
    // ΔE*ab of each pair computed by colour-science 0.4.7 (second implementation).
    let text = include_str!("data/sharma2005_ciede2000.csv");
    let mut n = 0;
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let (c1, c2) = (
            Lab::new(v[1], v[2], v[3]).unwrap(),
            Lab::new(v[4], v[5], v[6]).unwrap(),
        );
        let pair = v[0];
        let de = delta_e_2000(&c1, &c2);
        assert!((de - v[7]).abs() < 1e-4, "pair {pair}: {de} vs {}", v[7]);
        assert!(
            (delta_e_2000(&c2, &c1) - v[7]).abs() < 1e-4,
            "pair {pair} reversed"
        );
        assert!(
            (delta_e_94(&c1, &c2, Cie94::GRAPHIC_ARTS) - v[8]).abs() < 1e-7,
            "pair {pair} ΔE94"
        );
        assert!(
            (delta_e_94(&c1, &c2, Cie94::TEXTILES) - v[9]).abs() < 1e-7,
            "pair {pair} ΔE94 textiles"
        );
        assert!(
            (delta_e_ab(&c1, &c2) - v[10]).abs() < 1e-7,
            "pair {pair} ΔE*ab"
        );
        n += 1;
    }
    assert_eq!(n, 34);
}

#[test]
fn tables_are_on_the_documented_grid() {
    assert_eq!(tables::ROWS, 471);
    assert_eq!((tables::START_NM, tables::END_NM), (360, 830));
}
