//! Thread-count control and interruption. Every parallel entry point takes `n_threads`
//! (None = all cores) and runs inside a rayon pool of that size owned by this module.
//!
//! - Fork safety: a pool's threads do not survive `fork()` (the child has only the thread
//!   that forked), and neither do rayon's global pool's. So no call relies on the global
//!   pool (None builds a pool of all cores here), and the pool cache records the process
//!   that built it: a forked child finds a different pid, forgets the parent's pools (they
//!   cannot be shut down: their threads and locks belong to the parent) and builds its own.
//! - One pool per call: a call leases a pool of its size and returns it when done, so
//!   concurrent calls (from several Python threads) never queue on one pool.
//! - A bounded cache: at most [`MAX_POOLS`] idle pools are kept, the least recently used is
//!   dropped (its threads exit).
//! - Interruption: long calls run in chunks, each chunk parallel inside the pool, and call
//!   [`checkpoint`] between chunks on the calling thread; a caller (the Python binding)
//!   installs a check there with [`interruptible`] (e.g. "has Ctrl-C been pressed?").

use std::cell::RefCell;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex, MutexGuard};
use std::time::Duration;

use rayon::{ThreadPool, ThreadPoolBuilder};

use crate::infra::error::{Error, Result};

/// Largest thread count accepted (far above any real machine; guards against typos).
pub const MAX_THREADS: usize = 1024;
/// Most idle thread pools kept alive (least recently used dropped first); the pools of
/// calls running at the time come on top.
pub const MAX_POOLS: usize = 4;

struct Cache {
    /// The process that built `pools`.
    pid: u32,
    /// Use counter: `pools[i].1` is the tick of the pool's last use.
    tick: u64,
    /// Idle pools: (threads, tick of last use, pool). A pool in use by a call is not here.
    pools: Vec<(usize, u64, ThreadPool, Arc<AtomicBool>)>,
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

/// A pool of `n` threads leased by one call: concurrent calls never share a pool (a
/// shared pool ran them one after the other: two calls with `n_threads = 1` from two
/// Python threads took as long as in series). Dropping the lease returns the pool to the
/// idle cache (at most [`MAX_POOLS`] kept, the least recently used dropped first: its
/// threads exit).
struct Lease {
    n: usize,
    pid: u32,
    pool: Option<ThreadPool>,
    /// The pool's stop flag, read by [`checkpoint`] on its worker threads.
    stop: Arc<AtomicBool>,
}

impl Lease {
    fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(p) => p.install(f),
            None => f(), // never: the pool is only taken out by drop
        }
    }
}

impl Drop for Lease {
    fn drop(&mut self) {
        let Some(pool) = self.pool.take() else {
            return;
        };
        let mut c = cache();
        if c.pid != self.pid {
            // Leased before a fork, returned in the child: its threads are the parent's.
            std::mem::forget(pool);
            return;
        }
        c.tick += 1;
        let tick = c.tick;
        if c.pools.len() >= MAX_POOLS {
            let oldest = (0..c.pools.len())
                .min_by_key(|&i| c.pools[i].1)
                .unwrap_or(0);
            let dropped = c.pools.swap_remove(oldest);
            drop(c); // its threads are told to exit outside the lock
            drop(dropped);
            c = cache();
        }
        self.stop.store(false, Ordering::Relaxed);
        c.pools.push((self.n, tick, pool, Arc::clone(&self.stop)));
    }
}

/// Lease an idle pool of `n` threads of this process, or build one (outside the cache
/// lock, so the lock is only ever held for a lookup).
fn lease(n: usize) -> Result<Lease> {
    let pid = {
        let mut c = cache();
        if let Some(i) = c.pools.iter().position(|e| e.0 == n) {
            let (_, _, pool, stop) = c.pools.swap_remove(i);
            return Ok(Lease {
                n,
                pid: c.pid,
                pool: Some(pool),
                stop,
            });
        }
        c.pid
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let pool = ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("splitlf-{i}"))
        .start_handler(move |_| POOL_STOP.with(|s| *s.borrow_mut() = Some(Arc::clone(&flag))))
        .build()
        .map_err(|e| Error::param("n_threads", n, format!("a pool that can be started ({e})")))?;
    Ok(Lease {
        n,
        pid,
        pool: Some(pool),
        stop,
    })
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
    Ok(lease(threads(n_threads))?.install(f))
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
    let pool = lease(threads(n_threads))?;
    let step = step.max(1);
    let mut start = 0;
    while start < n {
        let end = start.saturating_add(step).min(n);
        let range = start..end;
        watched(&pool, || work(range))?;
        start = end;
        if start < n {
            checkpoint()?;
        }
    }
    Ok(())
}

/// Run `step` again and again inside the pool of `n_threads` until it returns `Ok(true)`,
/// with a [`checkpoint`] on the calling thread between calls: for an iteration whose
/// length is not known in advance (a solver that stops when it has converged).
pub fn repeat_until(
    n_threads: Option<usize>,
    mut step: impl FnMut() -> Result<bool> + Send,
) -> Result<()> {
    check_threads(n_threads)?;
    let pool = lease(threads(n_threads))?;
    loop {
        if watched(&pool, &mut step)? {
            return Ok(());
        }
        checkpoint()?;
    }
}

/// [`repeat_until`] on the pool the calling thread runs in (a worker of a call's pool, as
/// inside [`for_chunks`]), with a [`checkpoint`] between calls: for one of several such
/// loops run side by side in that pool.
pub fn repeat_here(step: &mut (dyn FnMut() -> Result<bool> + Send)) -> Result<()> {
    loop {
        if step()? {
            return Ok(());
        }
        checkpoint()?;
    }
}

/// Items per chunk of [`for_chunks`] when one item costs about `cost` elementary steps: a
/// chunk is about 2^22 steps per thread (tens of milliseconds), at least one item per thread.
pub fn chunk_items(n_threads: Option<usize>, cost: u128) -> usize {
    let t = threads(n_threads) as u128;
    let per = (t << 22) / cost.max(1);
    per.clamp(t, 1 << 40) as usize
}

/// How often a calling thread waiting for work of its call asks its interrupt check.
const WATCH_EVERY: Duration = Duration::from_millis(20);

/// Run `f` in the leased pool. With an interrupt check installed on the calling thread,
/// the calling thread waits for `f` (run by a helper thread) and asks the check every
/// [`WATCH_EVERY`]; when it says stop, the pool's stop flag makes every [`checkpoint`]
/// inside `f`, on any of the pool's threads, return [`Error::Interrupted`]. Without a check
/// `f` runs as `install` runs it.
fn watched<R: Send>(pool: &Lease, f: impl FnOnce() -> Result<R> + Send) -> Result<R> {
    if !HOOK.with(|h| h.borrow().is_some()) {
        return pool.install(f);
    }
    let caller = std::thread::current();
    std::thread::scope(|s| {
        let helper = s.spawn(|| {
            let r = pool.install(f);
            caller.unpark();
            r
        });
        let mut stopped = false;
        while !helper.is_finished() {
            std::thread::park_timeout(WATCH_EVERY);
            if !stopped && !helper.is_finished() && checkpoint().is_err() {
                pool.stop.store(true, Ordering::Relaxed);
                stopped = true;
            }
        }
        let r = helper
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        if stopped {
            Err(Error::Interrupted)
        } else {
            r
        }
    })
}

/// Run `f` on a thread of its own and wait for it, asking [`checkpoint`] every
/// [`WATCH_EVERY`]: for one long step that has no checkpoints of its own (a library call).
/// When the check says stop, the call returns [`Error::Interrupted`] at once and `f`
/// finishes in the background, its result dropped (so `f` owns what it uses).
pub fn detached<R: Send + 'static>(f: impl FnOnce() -> R + Send + 'static) -> Result<R> {
    if !HOOK.with(|h| h.borrow().is_some()) && !POOL_STOP.with(|s| s.borrow().is_some()) {
        return Ok(f());
    }
    let (tx, rx) = mpsc::sync_channel(1);
    std::thread::Builder::new()
        .name("splitlf-detached".into())
        .spawn(move || {
            let _ = tx.send(f());
        })
        .map_err(|e| {
            Error::param(
                "n_threads",
                1,
                format!("a thread that can be started ({e})"),
            )
        })?;
    loop {
        match rx.recv_timeout(WATCH_EVERY) {
            Ok(r) => return Ok(r),
            Err(mpsc::RecvTimeoutError::Timeout) => checkpoint()?,
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(Error::param("n_threads", 1, "a thread that does not panic"))
            }
        }
    }
}

type Hook = Box<dyn FnMut() -> bool>;

thread_local! {
    static HOOK: RefCell<Option<Hook>> = const { RefCell::new(None) };
    /// On a pool's worker thread: the pool's stop flag (set when the call that leased the
    /// pool is interrupted).
    static POOL_STOP: RefCell<Option<Arc<AtomicBool>>> = const { RefCell::new(None) };
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

/// Between two chunks of a long call: on a pool's worker, whether the call was stopped;
/// on the calling thread, ask the interrupt check installed by [`interruptible`] (none:
/// continue). Cheap enough for every few milliseconds of work.
pub fn checkpoint() -> Result<()> {
    let pool_stopped = POOL_STOP.with(|s| {
        s.borrow()
            .as_ref()
            .is_some_and(|f| f.load(Ordering::Relaxed))
    });
    if pool_stopped {
        return Err(Error::Interrupted);
    }
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
        // A pool is reused once returned, and never shared by two calls at once.
        let a = lease(3).unwrap();
        let id = |l: &Lease| l.pool.as_ref().map(|p| p as *const ThreadPool as usize);
        let b = lease(3).unwrap();
        assert_ne!(id(&a), id(&b));
        assert_eq!(b.install(rayon::current_num_threads), 3);
        drop((a, b));
        assert!(cache().pools.len() <= MAX_POOLS);
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
        // The check runs between chunks, and also while the caller waits for a chunk (every
        // WATCH_EVERY): under load a chunk can outlast that, so the second "stop" may come
        // before the second chunk. Either way the call stops at once, far before chunk 10.
        assert_eq!(calls.get(), 2);
        assert!((1..=2).contains(&done), "{done} chunks ran");
        assert!(checkpoint().is_ok()); // the check is gone with its scope
    }
}
