//! Thread-count control and interruption. Every parallel entry point takes `n_threads`
//! (None = all cores) and runs inside a rayon pool of that size owned by this module.
//!
//! - Fork safety: a pool's threads do not survive `fork()` (the child has only the thread
//!   that forked), and neither do rayon's global pool's. So no call relies on the global
//!   pool (None builds a pool of all cores here), and the pool cache records the process
//!   that built it: a forked child finds a different pid, forgets the parent's pools (they
//!   cannot be shut down: their threads and locks belong to the parent) and builds its own.
//! - A bounded cache: at most [`MAX_POOLS`] pools are kept, the least recently used is
//!   dropped (its threads exit when the last call using it returns).
//! - Interruption: long calls run in chunks, each chunk parallel inside the pool, and call
//!   [`checkpoint`] between chunks on the calling thread; a caller (the Python binding)
//!   installs a check there with [`interruptible`] (e.g. "has Ctrl-C been pressed?").

use std::cell::RefCell;
use std::ops::Range;
use std::sync::{Arc, Mutex, MutexGuard};

use rayon::{ThreadPool, ThreadPoolBuilder};

use crate::error::{Error, Result};

/// Largest thread count accepted (far above any real machine; guards against typos).
pub const MAX_THREADS: usize = 1024;
/// Most thread pools kept alive at once (one per distinct thread count, least recently
/// used dropped first).
pub const MAX_POOLS: usize = 4;

struct Cache {
    /// The process that built `pools`.
    pid: u32,
    /// Use counter: `pools[i].1` is the tick of the pool's last use.
    tick: u64,
    pools: Vec<(usize, u64, Arc<ThreadPool>)>,
}

static CACHE: Mutex<Cache> = Mutex::new(Cache {
    pid: 0,
    tick: 0,
    pools: Vec::new(),
});

/// The cache, emptied first when it was filled by another process (we are a forked child).
fn cache() -> MutexGuard<'static, Cache> {
    let mut c = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let pid = std::process::id();
    if c.pid != pid {
        // The parent's pools: their worker threads do not exist in this process, and
        // dropping them could wait on locks held by those threads. Leak them.
        std::mem::forget(std::mem::take(&mut c.pools));
        c.pid = pid;
    }
    c
}

/// Threads of "all cores": the machine's available parallelism (at most MAX_THREADS).
pub fn all_cores() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(MAX_THREADS)
}

/// Threads a call with `n_threads` uses (None: all cores).
pub fn threads(n_threads: Option<usize>) -> usize {
    n_threads.unwrap_or_else(all_cores)
}

/// The pool of `n` threads of this process, built on first use (outside the cache lock,
/// so the lock is only ever held for a lookup).
fn pool(n: usize) -> Result<Arc<ThreadPool>> {
    {
        let mut c = cache();
        c.tick += 1;
        let tick = c.tick;
        if let Some(e) = c.pools.iter_mut().find(|e| e.0 == n) {
            e.1 = tick;
            return Ok(Arc::clone(&e.2));
        }
    }
    let built = ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("splitlf-{i}"))
        .build()
        .map_err(|e| Error::param("n_threads", n, format!("a pool that can be started ({e})")))?;
    let built = Arc::new(built);
    let mut c = cache();
    c.tick += 1;
    let tick = c.tick;
    if let Some(e) = c.pools.iter_mut().find(|e| e.0 == n) {
        // Another thread built one meanwhile: use it, drop ours.
        e.1 = tick;
        return Ok(Arc::clone(&e.2));
    }
    if c.pools.len() >= MAX_POOLS {
        let oldest = (0..c.pools.len())
            .min_by_key(|&i| c.pools[i].1)
            .unwrap_or(0);
        c.pools.swap_remove(oldest);
    }
    c.pools.push((n, tick, Arc::clone(&built)));
    Ok(built)
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

/// Run `f` on this process's pool of `n_threads` threads (None: all cores).
pub fn with_threads<R: Send>(n_threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    check_threads(n_threads)?;
    Ok(pool(threads(n_threads))?.install(f))
}

/// Run `work` on consecutive ranges of at most `step` items covering 0..n, each inside the
/// pool of `n_threads`, with a [`checkpoint`] between ranges on the calling thread.
pub fn for_chunks(
    n_threads: Option<usize>,
    n: usize,
    step: usize,
    mut work: impl FnMut(Range<usize>) -> Result<()> + Send,
) -> Result<()> {
    check_threads(n_threads)?;
    let pool = pool(threads(n_threads))?;
    let step = step.max(1);
    let mut start = 0;
    while start < n {
        let end = start.saturating_add(step).min(n);
        pool.install(|| work(start..end))?;
        start = end;
        if start < n {
            checkpoint()?;
        }
    }
    Ok(())
}

/// Items per chunk of [`for_chunks`] when one item costs about `cost` elementary steps: a
/// chunk is about 2^22 steps per thread (tens of milliseconds), at least one item per thread.
pub fn chunk_items(n_threads: Option<usize>, cost: u128) -> usize {
    let t = threads(n_threads) as u128;
    let per = (t << 22) / cost.max(1);
    per.clamp(t, 1 << 40) as usize
}

type Hook = Box<dyn FnMut() -> bool>;

thread_local! {
    static HOOK: RefCell<Option<Hook>> = const { RefCell::new(None) };
}

/// Run `f` with `stop` as this thread's interrupt check: [`checkpoint`] calls it, and a
/// `true` makes the running core call return [`Error::Interrupted`].
pub fn interruptible<R>(stop: impl FnMut() -> bool + 'static, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Hook>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let previous = self.0.take();
            HOOK.with(|h| *h.borrow_mut() = previous);
        }
    }
    let previous = HOOK.with(|h| h.borrow_mut().replace(Box::new(stop)));
    let _restore = Restore(previous);
    f()
}

/// Between two chunks of a long call: ask the interrupt check installed on this thread by
/// [`interruptible`] (none: continue).
pub fn checkpoint() -> Result<()> {
    // Taken out while it runs: the check may run code that calls the core again.
    let Some(mut stop) = HOOK.with(|h| h.borrow_mut().take()) else {
        return Ok(());
    };
    let stopped = stop();
    HOOK.with(|h| {
        let mut slot = h.borrow_mut();
        if slot.is_none() {
            *slot = Some(stop);
        }
    });
    if stopped {
        Err(Error::Interrupted)
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;
    use std::rc::Rc;

    #[test]
    fn pools_are_bounded_and_reused() {
        for n in 1..=12 {
            assert_eq!(
                with_threads(Some(n), rayon::current_num_threads).unwrap(),
                n
            );
        }
        assert!(cache().pools.len() <= MAX_POOLS);
        let a = pool(3).unwrap();
        let b = pool(3).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert!(with_threads(Some(0), || ()).is_err());
        assert!(with_threads(Some(MAX_THREADS + 1), || ()).is_err());
        assert_eq!(
            with_threads(None, rayon::current_num_threads).unwrap(),
            all_cores()
        );
    }

    #[test]
    fn chunks_cover_the_range_and_stop_when_asked() {
        let mut seen = Vec::new();
        for_chunks(Some(2), 10, 3, |r| {
            seen.push(r);
            Ok(())
        })
        .unwrap();
        assert_eq!(seen, vec![0..3, 3..6, 6..9, 9..10]);
        let calls = Rc::new(Cell::new(0));
        let c = Rc::clone(&calls);
        let mut done = 0;
        let r = interruptible(
            move || {
                c.set(c.get() + 1);
                c.get() >= 2
            },
            || {
                for_chunks(Some(1), 100, 10, |_| {
                    done += 1;
                    Ok(())
                })
            },
        );
        assert_eq!(r, Err(Error::Interrupted));
        assert_eq!((calls.get(), done), (2, 2));
        assert!(checkpoint().is_ok()); // the check is gone with its scope
    }
}
