//! Argument conversion, NumPy arrays in and out, the mapping of core errors to Python exceptions, and interruptible parallel calls (GIL released, Ctrl-C checked between chunks).

pub(crate) mod args;
pub(crate) mod arrays;
pub(crate) mod errors;
pub(crate) mod interrupt;
