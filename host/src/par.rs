//! Work spread over rayon's pool when the caller asks for it (`parallel`) and the `parallel`
//! feature brings rayon; the same work on this thread otherwise (the WASM build, or a build asked
//! to stay on one thread). The builder and the serializer use these, and their results never
//! depend on the thread count: each piece of work writes its own part of the answer.

/// Runs `a` and `b`, at once on the pool when `parallel`, else one after the other.
pub fn join<A: Send, B: Send>(
    parallel: bool,
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    #[cfg(feature = "parallel")]
    if parallel {
        return rayon::join(a, b);
    }
    let _ = parallel;
    (a(), b())
}

/// Items a task takes in [`fill`] and [`map`]: large enough that a task outweighs its scheduling.
#[cfg(feature = "parallel")]
const TASK_ITEMS: usize = 16 * 1024;

/// Calls `f(i, chunk)` for the `i`-th run of `width` items of `out` (the last may be shorter),
/// the runs shared out over the pool when `parallel`.
pub fn fill<T: Send>(
    parallel: bool,
    out: &mut [T],
    width: usize,
    f: impl Fn(usize, &mut [T]) + Sync + Send,
) {
    let width = width.max(1);
    #[cfg(feature = "parallel")]
    if parallel && out.len() > TASK_ITEMS {
        use rayon::prelude::*;
        let per_task = TASK_ITEMS.div_ceil(width).max(1);
        out.par_chunks_mut(per_task * width)
            .enumerate()
            .for_each(|(t, task)| {
                for (k, run) in task.chunks_mut(width).enumerate() {
                    f(t * per_task + k, run);
                }
            });
        return;
    }
    let _ = parallel;
    for (i, run) in out.chunks_mut(width).enumerate() {
        f(i, run);
    }
}

/// `f(i)` for `i` in `0..n`, in order, computed over the pool when `parallel`.
pub fn map<T: Send>(parallel: bool, n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    #[cfg(feature = "parallel")]
    if parallel && n > TASK_ITEMS {
        use rayon::prelude::*;
        return (0..n)
            .into_par_iter()
            .with_min_len(TASK_ITEMS)
            .map(f)
            .collect();
    }
    let _ = parallel;
    (0..n).map(f).collect()
}

/// `f(i)` for `i` in `0..n`, in order, each a task of its own when `parallel`: for a few large
/// pieces of work.
pub fn map_each<T: Send>(parallel: bool, n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    #[cfg(feature = "parallel")]
    if parallel {
        use rayon::prelude::*;
        return (0..n).into_par_iter().map(f).collect();
    }
    let _ = parallel;
    (0..n).map(f).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_gives_each_run_its_index_in_both_modes() {
        for parallel in [false, true] {
            for (n, width) in [(0, 3), (7, 3), (100_003, 10), (50_000, 1)] {
                let mut out = vec![usize::MAX; n];
                fill(parallel, &mut out, width, |i, run| {
                    assert!(run.len() == width || (i + 1) * width >= n);
                    run.fill(i);
                });
                assert!(out.iter().enumerate().all(|(k, &i)| i == k / width));
            }
        }
    }

    #[test]
    fn the_maps_keep_the_order_in_both_modes() {
        for parallel in [false, true] {
            for n in [0, 5, 100_000] {
                let want: Vec<usize> = (0..n).map(|i| 3 * i).collect();
                assert_eq!(map(parallel, n, |i| 3 * i), want);
                assert_eq!(map_each(parallel, n, |i| 3 * i), want);
            }
        }
    }
}
