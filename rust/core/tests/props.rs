//! Property tests of the core's public functions on random designs: for valid designs no
//! panic and every result finite, sorted and consistent as documented (docs/model.md); for
//! invalid parameters an `Err` naming the parameter, never a panic.
//!
//! Designs are small (K_x, K_y ≤ 40, Q ≤ 16) so that the whole target runs in seconds in a
//! debug build. Under CI (the `CI` environment variable set) the seed is fixed, so every run
//! draws the same cases; elsewhere it is random unless `PROPTEST_RNG_SEED` is set.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use splitlf_core::model::camera::CameraSpec;
use splitlf_core::model::lens::{MAX_K, MAX_Q};
use splitlf_core::model::optics::{design_curves, design_depth_of_field, Intervals, LensOptics};
use splitlf_core::sampling::line::Line;
use splitlf_core::sampling::rayspace::{trace_line, Sample};
use splitlf_core::sampling::samples::{design_coincidence_planes, design_new_samples, MAX_PAIRS};
use splitlf_core::{Axis, Camera, Design, Error, Half};

/// The seed under CI.
const CI_SEED: u64 = 0x5EED;

/// `cases` cases; the fixed [`CI_SEED`] under CI (unless `PROPTEST_RNG_SEED` is set). No
/// regression files: a failure prints its minimal input, to be kept as a plain test.
fn config(cases: u32) -> ProptestConfig {
    let mut c = ProptestConfig::with_cases(cases);
    c.failure_persistence = None;
    if std::env::var_os("CI").is_some() && c.rng_seed == RngSeed::Random {
        c.rng_seed = RngSeed::Fixed(CI_SEED);
    }
    c
}

/// Floats log-uniform in [lo, hi].
fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..=hi.ln()).prop_map(f64::exp)
}

/// The arguments of [`Camera::new`], in its order.
#[derive(Debug, Clone, Copy)]
struct Fields {
    lengths: [f64; 7],
    counts: [i64; 3],
    focal: [Option<f64>; 2],
}

/// Names of the fields as the core's errors give them, in [`Camera::new`]'s order.
const NAMES: [&str; 12] = [
    "F", "D", "v1", "kappa", "d", "v", "mu", "Q", "Kx", "Ky", "f1", "f2",
];

impl Fields {
    fn camera(&self) -> Result<Camera, Error> {
        let [f_main, aperture, v1, kappa, d, v, mu] = self.lengths;
        let [q, kx, ky] = self.counts;
        let [f1, f2] = self.focal;
        Camera::new(&CameraSpec {
            f_main,
            aperture,
            v1,
            kappa,
            d,
            v,
            mu,
            q,
            kx,
            ky,
            f1,
            f2,
        })
    }
}

prop_compose! {
    /// A valid design: v1 > F, kappa ≥ 0 (sometimes exactly 0), mu = d / Q, f-number matched
    /// on half 1 or v down to 0.2× the matched one (a larger v makes neighbouring microlens
    /// images overlap, which the design refuses), Ng's setting or explicit focal lengths.
    fn design_fields()(
        f_main in log_uniform(5.0, 500.0),
        q in 1i64..=16,
        d in log_uniform(0.005, 1.0),
        rel_v1 in log_uniform(1e-3, 3.0),
        f_number in log_uniform(0.7, 32.0),
        mismatch in prop_oneof![Just(1.0), log_uniform(0.2, 1.0)],
        kappa in prop_oneof![Just(0.0), log_uniform(1e-4, 3.0)],
        kx in 1i64..=40,
        ky in 1i64..=40,
        f1 in proptest::option::of(log_uniform(0.2, 5.0)),
        f2 in proptest::option::of(log_uniform(0.2, 5.0)),
    ) -> Fields {
        let v1 = f_main * (1.0 + rel_v1);
        let aperture = f_main / f_number;
        let v = d * v1 / aperture * mismatch;
        Fields {
            lengths: [f_main, aperture, v1, kappa, d, v, d / q as f64],
            counts: [q, kx, ky],
            focal: [f1.map(|k| k * v), f2.map(|k| k * v)],
        }
    }
}

prop_compose! {
    fn design()(fields in design_fields()) -> Camera {
        fields.camera().expect("a valid design is accepted")
    }
}

prop_compose! {
    /// A design and depths > F from just beyond F to 10^5 F, with (sometimes) both
    /// out-of-focus planes.
    fn design_and_depths()(
        cam in design(),
        rel in proptest::collection::vec(log_uniform(1e-6, 1e5), 1..8),
        planes in any::<bool>(),
    ) -> (Camera, Vec<f64>) {
        let mut z: Vec<f64> = rel.iter().map(|r| cam.f_main * (1.0 + r)).collect();
        if planes {
            let d = cam.design();
            z.extend(Half::BOTH.map(|h| optics(&d, h).out_of_focus_depth()));
        }
        (cam, z)
    }
}

/// Half h of the camera as the closed forms see it: channel h of its design, type 0.
fn optics(d: &Design, h: Half) -> LensOptics {
    LensOptics::of_channel(d, &d.channels[h.index()], 0)
}

/// Channel number (from 1) of half h.
fn number(h: Half) -> i64 {
    h.index() as i64 + 1
}

/// Lit pixels along x under one lens of half h (Q_lit).
fn lit_pixels(d: &Design, h: Half) -> u64 {
    let line = Line::of_channel(d, number(h), Axis::X).unwrap();
    (0..line.q().unwrap())
        .filter(|&i| line.pixel(i).lit)
        .count() as u64
}

fn half() -> impl Strategy<Value = Half> {
    prop_oneof![Just(Half::One), Just(Half::Two)]
}

fn assert_intervals(iv: &Intervals, f_main: f64) {
    for &(lo, hi) in iv {
        assert!(f_main <= lo && lo < hi, "{iv:?}");
    }
    for w in iv.windows(2) {
        assert!(w[0].1 <= w[1].0, "not sorted and disjoint: {iv:?}");
    }
}

proptest! {
    #![proptest_config(config(1024))]

    #[test]
    fn curves_are_finite((cam, z) in design_and_depths()) {
        let d = cam.design();
        let c = design_curves(&d, &z, None).unwrap();
        let n = z.len();
        for &zc in &c.conjugate {
            prop_assert!(zc.is_finite() && zc >= cam.f_main, "z' = {zc}");
        }
        for row in [&c.main_blur, &c.repetitions, &c.blur_px, &c.conventional_px] {
            prop_assert_eq!(row.len(), 2 * n);
            prop_assert!(row.iter().all(|x| x.is_finite() && *x >= 0.0), "{row:?}");
        }
        for h in Half::BOTH {
            let (l, r) = (cam.array_plane(h), optics(&d, h).image_radius() / cam.mu);
            for k in 0..n {
                let b = c.microlens_blur[h.index() * n + k];
                // b_i is unbounded only where z' lies on array i (docs/model.md §2).
                prop_assert!(b >= 0.0, "b = {b}");
                prop_assert_eq!(b.is_infinite(), c.conjugate[k] == l);
                prop_assert!(c.blur_px[h.index() * n + k] <= r);
            }
        }
    }

    #[test]
    fn depth_of_field_is_sorted_and_the_split_contains_each_half(
        cam in design(),
        t in log_uniform(0.05, 20.0),
    ) {
        let dof = design_depth_of_field(&cam.design(), t).unwrap();
        let all = dof.types.iter().chain(&dof.channels).chain(&dof.conventional);
        for iv in all.chain([&dof.union]) {
            assert_intervals(iv, cam.f_main);
        }
        for &(lo, hi) in dof.channels.iter().flatten() {
            prop_assert!(
                dof.union.iter().any(|&(a, b)| a <= lo && hi <= b),
                "({lo}, {hi}) not in {:?}", dof.union
            );
        }
    }

    #[test]
    fn counted_equals_eqs_8_9(
        cam in design(),
        h in half(),
        max_n in 1i64..=4,
        max_t in proptest::option::of(1i64..=16),
    ) {
        let planes =
            design_coincidence_planes(&cam.design(), number(h), max_n, max_t, None).unwrap();
        for p in &planes {
            prop_assert_eq!(p.counted, p.new_samples, "{:?}", p);
            prop_assert_eq!(p.new_samples, p.new_samples_x * p.new_samples_y);
            prop_assert!(p.z.is_finite() && p.z > cam.f_main && p.conjugate > cam.f_main);
            prop_assert!(p.repetitions.is_finite());
        }
        prop_assert!(planes.windows(2).all(|w| w[0].z <= w[1].z));
    }

    #[test]
    fn trace_areas_and_lit_pixels(cam in design(), h in half(), y in any::<bool>()) {
        let axis = if y { Axis::Y } else { Axis::X };
        let tr = trace_line(&Line::of_channel(&cam.design(), number(h), axis).unwrap()).unwrap();
        let q = cam.q as usize;
        let lenses = if y { cam.ky } else { cam.kx };
        prop_assert_eq!(tr.area.len(), lenses as usize * q);
        // The light of one microlens is at most the rays through it and the aperture,
        // D d v'/L_i, up to rounding: vertices sit at |u| up to |b| D / (2a) (b = 1 - L_i/v')
        // while a pixel's polygon is d/a wide, so areas carry a relative error of about
        // eps (1 + |b| D / d) (measured up to 43 times that, 1.7e-11 at D/d ~ 10^5).
        let l = cam.array_plane(h);
        let full = cam.aperture * cam.d * cam.v1 / l;
        let cond = 1.0 + (1.0 - l / cam.v1).abs() * cam.aperture / cam.d;
        for lens in tr.area.chunks(q) {
            let sum: f64 = lens.iter().sum();
            prop_assert!(sum <= full * (1.0 + 256.0 * f64::EPSILON * cond), "{} > {}", sum, full);
        }
        for i in 0..tr.area.len() {
            let a = tr.area[i];
            prop_assert!(a.is_finite() && a >= 0.0);
            prop_assert_eq!(a == 0.0, tr.centroid[i][0].is_nan(), "pixel {}", i);
            prop_assert!(tr.chief[i].iter().all(|c| c.is_finite()));
            // A lit pixel's chief ray is inside its polygon: it collects light.
            prop_assert!(!tr.lit[i] || a > 0.0, "pixel {} lit with area {}", i, a);
        }
    }
}

proptest! {
    #![proptest_config(config(512))]

    #[test]
    fn new_samples_union_bounds(
        (cam, mut z) in design_and_depths(),
        centroid in any::<bool>(),
    ) {
        // The coincidence planes too, where samples merge and the counts dip.
        let d = cam.design();
        for h in Half::BOTH {
            let planes = design_coincidence_planes(&d, number(h), 2, None, None).unwrap();
            z.extend(planes.iter().map(|p| p.z));
        }
        let mode = if centroid { Sample::Centroid } else { Sample::Chief };
        let s = design_new_samples(&d, &z, 1e-6, mode, None).unwrap();
        let m = z.len();
        let row = |v: &[u64], r: usize, k: usize| v[r * m + k];
        let lit = &s.sampled;
        prop_assert_eq!(lit[2], lit[0] + lit[1]);
        if !centroid {
            for h in Half::BOTH {
                prop_assert_eq!(lit[h.index()], cam.kx as u64 * lit_pixels(&d, h));
            }
        }
        for (k, zk) in z.iter().enumerate() {
            let d = |r| row(&s.distinct, r, k);
            let (d1, d2, du) = (d(0), d(1), d(2));
            prop_assert!(du >= d1.max(d2) && du <= d1 + d2, "z = {}: {} {} {}", zk, d1, d2, du);
            prop_assert!(d1 <= lit[0] && d2 <= lit[1]);
            for r in 0..3 {
                let g = s.max_gap[r * m + k];
                prop_assert!(!g.is_nan() && g >= 0.0, "max_gap = {}", g);
            }
        }
    }

    #[test]
    fn chief_samples_collapse_on_out_of_focus_planes(cam in design()) {
        // docs/model.md §8: on z_i every lit pixel of microlens j samples c_j.
        let d = cam.design();
        for h in Half::BOTH {
            let z = optics(&d, h).out_of_focus_depth();
            let s = design_new_samples(&d, &[z], 1e-6, Sample::Chief, None).unwrap();
            let k = if lit_pixels(&d, h) > 0 { cam.kx as u64 } else { 0 };
            prop_assert_eq!(s.distinct[h.index()], k);
        }
    }
}

/// One invalid value for field `i` of [`NAMES`] (given the valid design's F for v1).
fn invalid_value(i: usize, f_main: f64) -> BoxedStrategy<Value> {
    let non_finite = prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)];
    match NAMES[i] {
        "Q" | "Kx" | "Ky" => {
            let max = (if i == 7 { MAX_Q } else { MAX_K }) as i64;
            prop_oneof![i64::MIN..=0, (max + 1)..=i64::MAX]
                .prop_map(Value::Count)
                .boxed()
        }
        "kappa" => prop_oneof![non_finite, f64::MIN..=-5e-324]
            .prop_map(Value::Length)
            .boxed(),
        "v1" => prop_oneof![
            non_finite,
            f64::MIN..=0.0,
            (0.0..=1.0).prop_map(move |k| k * f_main),
        ]
        .prop_map(Value::Length)
        .boxed(),
        _ => prop_oneof![
            non_finite,
            f64::MIN..=0.0,
            5e-324..2.2250738585072014e-308, // subnormal
        ]
        .prop_map(Value::Length)
        .boxed(),
    }
}

#[derive(Debug, Clone, Copy)]
enum Value {
    Length(f64),
    Count(i64),
}

prop_compose! {
    fn invalid_design()(fields in design_fields(), i in 0..NAMES.len())
        (value in invalid_value(i, fields.lengths[0]), fields in Just(fields), i in Just(i))
        -> (Fields, usize) {
        let mut fields = fields;
        match value {
            Value::Length(x) if i < 7 => fields.lengths[i] = x,
            Value::Length(x) => fields.focal[i - 10] = Some(x),
            Value::Count(n) => fields.counts[i - 7] = n,
        }
        (fields, i)
    }
}

/// `e` is an invalid parameter named `want`.
fn named(e: Error, want: &str) -> bool {
    matches!(e, Error::InvalidParameter { name, .. } if name == want)
}

proptest! {
    #![proptest_config(config(512))]

    #[test]
    fn invalid_fields_are_named_errors((fields, i) in invalid_design()) {
        match fields.camera() {
            Err(Error::InvalidParameter { name, .. }) => prop_assert_eq!(name, NAMES[i]),
            other => prop_assert!(false, "{} = {:?}: {:?}", NAMES[i], fields, other),
        }
    }

    #[test]
    fn invalid_call_parameters_are_errors(
        cam in design(),
        bad_z in prop_oneof![
            Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY), f64::MIN..=0.0,
            (0.0..=1.0f64),
        ],
        at in 0usize..4,
        bad_t in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), f64::MIN..=0.0],
        bad_tol in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), f64::MIN..-0.0],
        bad_n in prop_oneof![i64::MIN..=0, (MAX_PAIRS as i64 + 1)..=i64::MAX],
        bad_half in prop_oneof![i64::MIN..=0, 3..=i64::MAX],
    ) {
        // A depth that is not finite or not > F, at any index, is refused with its index.
        let bad_z = if bad_z.is_finite() && bad_z > 0.0 { bad_z * cam.f_main } else { bad_z };
        let mut z = vec![2.0 * cam.f_main; 4];
        z[at] = bad_z;
        let d = cam.design();
        let depth_error = |e: Error| matches!(e, Error::InvalidDepth { index, .. } if index == at);
        prop_assert!(depth_error(design_curves(&d, &z, None).unwrap_err()));
        for mode in [Sample::Chief, Sample::Centroid] {
            prop_assert!(depth_error(design_new_samples(&d, &z, 1e-6, mode, None).unwrap_err()));
        }
        prop_assert!(named(design_depth_of_field(&d, bad_t).unwrap_err(), "threshold_px"));
        let e = design_new_samples(&d, &[2.0 * cam.f_main], bad_tol, Sample::Chief, None).unwrap_err();
        prop_assert!(named(e, "tol"), "tol = {}", bad_tol);
        let e = design_coincidence_planes(&d, 1, bad_n, None, None).unwrap_err();
        prop_assert!(named(e, "max_n"));
        let e = design_coincidence_planes(&d, 2, 1, Some(bad_n), None).unwrap_err();
        prop_assert!(named(e, "max_t"));
        prop_assert!(named(Half::from_number(bad_half).unwrap_err(), "half"));
    }
}
