//! Bindings of sampling: ray space, coincidence planes and new samples, 2-D samples and coverage.

pub(crate) mod rayspace;
pub(crate) mod samples;
pub(crate) mod samples2d;
