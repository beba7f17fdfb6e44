//! Sampling: what a design records of the light field. One channel along one axis
//! ([`line`]), every pixel's integration polygon in (u, w) and its footprints (§3–5,
//! [`rayspace`]), coincidence planes and genuinely new samples (Eqs. 8–9, [`samples`]),
//! 2-D chief samples, distinct samples and covering radius (§9, [`samples2d`]) and the
//! figures of merit of one design that sweeps compare ([`merit`]). Uses
//! [`crate::infra`] and [`crate::model`].

pub mod line;
pub mod merit;
pub mod rayspace;
pub mod samples;
pub mod samples2d;
