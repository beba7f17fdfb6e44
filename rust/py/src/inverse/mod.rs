//! Bindings of inversion: the 1-D simulation, reconstruction and depth estimation.

pub(crate) mod depth;
pub(crate) mod merit;
pub(crate) mod reconstruct;
pub(crate) mod simulate;
