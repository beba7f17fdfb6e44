//! Thread-count control: every parallel entry point takes `n_threads` (None = all cores)
//! and runs inside a local rayon pool of that size. Pools are built once per size and kept.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::{ThreadPool, ThreadPoolBuilder};

use crate::error::{Error, Result};

/// Largest thread count accepted (far above any real machine; guards against typos).
pub const MAX_THREADS: usize = 1024;

fn pool(n: usize) -> Result<Arc<ThreadPool>> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<ThreadPool>>>> = OnceLock::new();
    let pools = POOLS.get_or_init(|| Mutex::new(HashMap::new()));
    let mut map = pools.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(p) = map.get(&n) {
        return Ok(Arc::clone(p));
    }
    let p = ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("splitlf-{i}"))
        .build()
        .map_err(|e| Error::param("n_threads", n, format!("a pool that can be started ({e})")))?;
    let p = Arc::new(p);
    map.insert(n, Arc::clone(&p));
    Ok(p)
}

/// Validate a thread count: `None` means all cores.
pub fn check_threads(n_threads: Option<usize>) -> Result<()> {
    match n_threads {
        Some(n) if n == 0 || n > MAX_THREADS => Err(Error::param(
            "n_threads",
            n,
            format!("an integer in [1, {MAX_THREADS}] or None for all cores"),
        )),
        _ => Ok(()),
    }
}

/// Run `f` on a pool of `n_threads` threads (None: the global pool, all cores).
pub fn with_threads<R: Send>(n_threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    check_threads(n_threads)?;
    match n_threads {
        None => Ok(f()),
        Some(n) => Ok(pool(n)?.install(f)),
    }
}

/// Number of threads a call with `n_threads` will use.
pub fn effective_threads(n_threads: Option<usize>) -> usize {
    n_threads.unwrap_or_else(rayon::current_num_threads)
}
