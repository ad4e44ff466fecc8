//! The order in which worker threads take an image's tiles.
//!
//! Each worker keeps its pruned fields (octrees of simplified tapes,
//! [`crate::prune`]) for every tile it renders, so the fewer regions of
//! space a worker's tiles reach, the fewer cells it builds and the sooner
//! its tapes are short. The tiles (in raster order) are cut into one
//! contiguous run per worker; a worker takes its own run's tiles in order
//! and, once its run is done, helps with the run that has the most left.

use std::sync::atomic::{AtomicUsize, Ordering};

/// Tiles `0..n` shared out among `workers` workers (see the module docs).
#[derive(Debug)]
pub struct TileQueue {
    /// Per run: its next tile and its end.
    runs: Vec<(AtomicUsize, usize)>,
}

impl TileQueue {
    /// `n` tiles for `workers` workers (at least one run).
    pub fn new(n: usize, workers: usize) -> TileQueue {
        let w = workers.max(1);
        TileQueue {
            runs: (0..w).map(|k| (AtomicUsize::new(k * n / w), (k + 1) * n / w)).collect(),
        }
    }

    /// The next tile for worker `worker`, None when every tile is taken.
    /// Every tile is handed out exactly once.
    pub fn take(&self, worker: usize) -> Option<usize> {
        let own = worker % self.runs.len();
        if let Some(t) = self.take_from(own) {
            return Some(t);
        }
        loop {
            // The run with the most tiles left.
            let (k, left) = (self.runs.iter().enumerate())
                .map(|(k, (next, end))| (k, end.saturating_sub(next.load(Ordering::Relaxed))))
                .max_by_key(|&(_, left)| left)?;
            if left == 0 {
                return None;
            }
            if let Some(t) = self.take_from(k) {
                return Some(t);
            }
        }
    }

    fn take_from(&self, run: usize) -> Option<usize> {
        let (next, end) = &self.runs[run];
        let t = next.fetch_add(1, Ordering::Relaxed);
        (t < *end).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every tile exactly once, whatever the number of workers and
    /// however they interleave; a worker starts with a contiguous run.
    #[test]
    fn every_tile_once() {
        for (n, w) in [(0, 1), (1, 3), (10, 1), (240, 2), (241, 3), (7, 16)] {
            let q = TileQueue::new(n, w);
            let mut seen = vec![0; n];
            let mut first: Vec<Vec<usize>> = vec![Vec::new(); w];
            let mut worker = 0;
            while let Some(t) = q.take(worker) {
                seen[t] += 1;
                first[worker].push(t);
                // An uneven interleaving: worker 0 takes three for each of the others'.
                worker = (worker + usize::from(t % 3 == 0)) % w;
            }
            assert!(seen.iter().all(|&c| c == 1), "{n} tiles, {w} workers: {seen:?}");
            assert!(q.take(0).is_none());
        }
        // Concurrently.
        let q = TileQueue::new(1000, 4);
        let counts: Vec<std::sync::atomic::AtomicU32> = (0..1000).map(|_| Default::default()).collect();
        std::thread::scope(|s| {
            for worker in 0..4 {
                let (q, counts) = (&q, &counts);
                s.spawn(move || {
                    while let Some(t) = q.take(worker) {
                        counts[t].fetch_add(1, Ordering::Relaxed);
                    }
                });
            }
        });
        assert!(counts.iter().all(|c| c.load(Ordering::Relaxed) == 1));
        // Two workers: the first halves, in order.
        let q = TileQueue::new(6, 2);
        assert_eq!(
            (q.take(0), q.take(1), q.take(0), q.take(1)),
            (Some(0), Some(3), Some(1), Some(4))
        );
    }
}
