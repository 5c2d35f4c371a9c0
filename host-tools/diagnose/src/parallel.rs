//! A small order-preserving parallel map over scoped threads (the workflow's independent
//! fits and simulations), with a callback on the calling thread as each result arrives.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

/// Number of worker threads for `requested` (0: the machine's available parallelism).
pub fn threads(requested: usize) -> usize {
    if requested > 0 {
        requested
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    }
}

/// `items.map(f)` in order, computed by up to `threads` threads taking items in the order
/// of `items`; `on_done(index, &result)` runs on the calling thread as each result
/// arrives (in completion order). With one thread (or one item) everything runs on the
/// calling thread. A panic in `f` propagates.
pub fn map<T, R, F>(items: &[T], threads: usize, f: F, mut on_done: impl FnMut(usize, &R)) -> Vec<R>
where
    T: Sync,
    R: Send,
    F: Fn(&T) -> R + Sync,
{
    let workers = threads.max(1).min(items.len());
    if workers <= 1 {
        return items
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let r = f(x);
                on_done(i, &r);
                r
            })
            .collect();
    }
    let next = AtomicUsize::new(0);
    let mut out: Vec<Option<R>> = (0..items.len()).map(|_| None).collect();
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel::<(usize, R)>();
        for _ in 0..workers {
            let tx = tx.clone();
            let (next, f) = (&next, &f);
            s.spawn(move || loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(x) = items.get(i) else { break };
                if tx.send((i, f(x))).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        // Ends when every worker has dropped its sender (finished, or panicked: the scope
        // then re-raises the panic).
        for (i, r) in rx {
            on_done(i, &r);
            out[i] = Some(r);
        }
    });
    out.into_iter()
        .map(|r| r.unwrap_or_else(|| unreachable!("every item is computed once")))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_order_and_reports_every_item() {
        let items: Vec<u64> = (0..100).collect();
        for threads in [1, 2, 5] {
            let mut seen = vec![false; items.len()];
            let out = map(
                &items,
                threads,
                |x| x * x,
                |i, r| {
                    assert_eq!(*r, items[i] * items[i]);
                    seen[i] = true;
                },
            );
            assert_eq!(out, items.iter().map(|x| x * x).collect::<Vec<_>>());
            assert!(seen.iter().all(|s| *s));
        }
    }
}
