//! `quality` against reference values from scikit-image, generated once by
//! `tests/data/make_ssim_vectors.py` and committed as `tests/data/ssim_vectors.json`
//! (the versions used are recorded in the file).

use serde::Deserialize;
use shadetrace_replay::images::Rgba8Image;
use shadetrace_replay::quality::{compare, luma, max_abs_error, psnr, psnr_for_report, ssim, ssim_map};

/// SSIM and PSNR are computed in the same order of operations as SciPy/NumPy (and the
/// Gaussian weights come out bit-identical), so every value here matches scikit-image
/// exactly: the observed difference is 0. The bound only leaves room for a future
/// reordering of the arithmetic (a few ulps, about 1e-15) while catching any real formula
/// difference.
const TOLERANCE: f64 = 1e-12;

#[derive(Deserialize)]
struct Vectors {
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    width: u32,
    height: u32,
    a: Vec<u8>,
    b: Vec<u8>,
    ssim: f64,
    psnr_db: Option<f64>,
    max_abs_error: u8,
    ssim_map: Option<Vec<f64>>,
}

/// RGB bytes to an image, with an arbitrary alpha pattern to show alpha is ignored.
fn image(width: u32, height: u32, rgb: &[u8]) -> Rgba8Image {
    let pixels = rgb
        .chunks_exact(3)
        .enumerate()
        .map(|(i, c)| [c[0], c[1], c[2], (i * 37 % 256) as u8])
        .collect();
    Rgba8Image { width, height, pixels }
}

fn vectors() -> Vectors {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ssim_vectors.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn ssim_psnr_and_max_error_match_scikit_image() {
    let cases = vectors().cases;
    assert!(cases.len() >= 6);
    for case in &cases {
        let (a, b) = (
            image(case.width, case.height, &case.a),
            image(case.width, case.height, &case.b),
        );
        let (la, lb) = (luma(&a), luma(&b));

        let got = ssim(&la, &lb, case.width, case.height).unwrap();
        assert!(
            (got - case.ssim).abs() < TOLERANCE,
            "{}: ssim {got:e} expected {:e}",
            case.name,
            case.ssim
        );

        if let Some(expected) = &case.ssim_map {
            let map = ssim_map(&la, &lb, case.width, case.height).unwrap();
            assert_eq!(map.len(), expected.len());
            for (i, (got, want)) in map.iter().zip(expected).enumerate() {
                assert!(
                    (got - want).abs() < TOLERANCE,
                    "{}: ssim map [{i}] {got:e} expected {want:e}",
                    case.name
                );
            }
        }

        match case.psnr_db {
            None => assert_eq!(psnr(&a, &b), f64::INFINITY, "{}", case.name),
            Some(expected) => {
                let got = psnr(&a, &b);
                assert!(
                    (got - expected).abs() < TOLERANCE,
                    "{}: psnr {got:e} expected {expected:e}",
                    case.name
                );
            }
        }
        assert_eq!(max_abs_error(&a, &b), case.max_abs_error, "{}", case.name);

        let quality = compare(&a, &b, &vec![true; a.pixels.len()]).unwrap();
        assert_eq!(quality.ssim, Some(got));
        assert_eq!(quality.psnr_db, psnr_for_report(&a, &b));
        assert_eq!(quality.max_abs_error, case.max_abs_error);
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let cases = vectors().cases;
    let run = |threads: usize| -> Vec<u64> {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            cases
                .iter()
                .map(|c| {
                    let (a, b) = (image(c.width, c.height, &c.a), image(c.width, c.height, &c.b));
                    ssim(&luma(&a), &luma(&b), c.width, c.height).unwrap().to_bits()
                })
                .collect()
        })
    };
    assert_eq!(run(1), run(4));
}
