//! The whites the sweep divides by (docs/depth.md, step 1): each channel's raw under a
//! white albedo (vignetting and the channel's share), with 0 (not valid) for the pixels of
//! a sensor layout that take less than a share of their white through their own lens
//! (the rest also see a neighbouring lens's footprint, far away on the scene, and their
//! value is a blend of the two). Rendered once per design and kept.

use std::sync::atomic::AtomicUsize;
use std::sync::{Arc, Mutex};

use crate::imaging::render::{self, RenderOptions};
use crate::imaging::scene::{Scene, Surface};
use crate::imaging::texture::Texture;
use crate::infra::error::Result;
use crate::infra::memory;
use crate::model::design::{Design, Layout};

/// Designs whose whites are kept (the least recently made first out).
const KEPT: usize = 4;

/// Every channel's whites (row-major, the §10 layout).
pub type Whites = Arc<Vec<Vec<f64>>>;

/// The kept whites: (design, own share's bits, whites).
static KEPT_WHITES: Mutex<Vec<(Design, u64, Whites)>> = Mutex::new(Vec::new());

/// The white scene: albedo 1 everywhere, on a fronto-parallel plane well in front of the
/// lens (2 F + 1000 mm; any depth gives the same raws: every ray a pixel collects meets a
/// fronto-parallel plane).
fn white_scene(design: &Design) -> Result<Scene> {
    let texture = Texture::from_parts("sinusoid", &[1.0, 1.0, 0.0, 0.0], None)?;
    let z = 2.0 * design.f_main + 1000.0;
    let surface = Surface::from_parts("plane", &[z, 0.0, 0.0], None)?;
    Scene::new(texture, surface, 1.0)
}

/// Whether any channel has a sensor layout (then the own-lens whites are rendered too).
fn any_sensor(design: &Design) -> bool {
    design
        .channels
        .iter()
        .any(|ch| matches!(ch.layout, Layout::Sensor { .. }))
}

/// The bytes [`sweep_whites`] allocates when the design's whites are not kept: the whites
/// and, on a sensor layout, the own-lens whites.
pub fn whites_bytes(design: &Design) -> u128 {
    render::render_bytes(design) * if any_sensor(design) { 2 } else { 1 }
}

/// The design's raws of the white scene, each pixel through every lens or (`own_lens`)
/// through its own alone, at the render's default error target.
fn render_white(
    design: &Design,
    own_lens: bool,
    n_threads: Option<usize>,
) -> Result<Vec<Vec<f64>>> {
    let scene = white_scene(design)?;
    let opts = RenderOptions {
        tol: render::DEFAULT_TOL,
        own_lens,
        ..RenderOptions::default()
    };
    let mut out = Vec::with_capacity(design.channels.len());
    for ch in &design.channels {
        let (r, c) = render::raw_shape(ch);
        out.push(memory::try_vec("the depth sweep's whites", r * c, 0.0)?);
    }
    let slices: Vec<&mut [f64]> = out.iter_mut().map(|v| v.as_mut_slice()).collect();
    render::render_into(
        design,
        &scene,
        opts,
        n_threads,
        &AtomicUsize::new(0),
        slices,
    )?;
    Ok(out)
}

/// The whites the sweep takes: the white scene's raws, with 0 for the pixels of a
/// sensor-layout design that take less than `min_own_share` of their white through their
/// own lens (the own-lens render of the same scene). On the ideal layout a pixel sees its
/// own lens alone, and the whites are the white scene's. Kept for the last [`KEPT`]
/// designs (and shares); the caller checks [`whites_bytes`] first.
pub fn sweep_whites(
    design: &Design,
    min_own_share: f64,
    n_threads: Option<usize>,
) -> Result<Whites> {
    let key = min_own_share.to_bits();
    let kept = |list: &Vec<(Design, u64, Whites)>| {
        list.iter()
            .find(|(d, k, _)| *k == key && d == design)
            .map(|e| Arc::clone(&e.2))
    };
    if let Some(w) = kept(&KEPT_WHITES.lock().unwrap_or_else(|p| p.into_inner())) {
        return Ok(w);
    }
    let mut whites = render_white(design, false, n_threads)?;
    if any_sensor(design) {
        let own = render_white(design, true, n_threads)?;
        for (w, o) in whites.iter_mut().zip(&own) {
            for (wv, &ov) in w.iter_mut().zip(o) {
                let own_enough = ov >= min_own_share * *wv;
                if !own_enough {
                    *wv = 0.0;
                }
            }
        }
    }
    let whites = Arc::new(whites);
    let mut list = KEPT_WHITES.lock().unwrap_or_else(|p| p.into_inner());
    if kept(&list).is_none() {
        if list.len() >= KEPT {
            list.remove(0);
        }
        list.push((design.clone(), key, Arc::clone(&whites)));
    }
    Ok(whites)
}
