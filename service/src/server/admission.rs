//! Bounded admission of heavy requests, and the cancel flag each one carries.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tonic::Status;

use crate::metrics::Metrics;

/// `max_concurrent` slots and a waiting line of `max_queue`.
pub(super) struct Admission {
    slots: Arc<Semaphore>,
    max_concurrent: usize,
    waiting: AtomicUsize,
    max_queue: usize,
    metrics: Arc<Metrics>,
}

/// Raises the cancel flag when dropped unless disarmed: the request's future was dropped.
struct CancelOnDrop(Arc<AtomicBool>, bool);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        if !self.1 {
            self.0.store(true, Ordering::Relaxed);
        }
    }
}

/// Counts a request in a gauge for as long as it lives, however it ends (a panic included).
struct Gauge<'a>(&'a Metrics, fn(&Metrics, i64));

impl<'a> Gauge<'a> {
    fn enter(metrics: &'a Metrics, add: fn(&Metrics, i64)) -> Gauge<'a> {
        add(metrics, 1);
        Gauge(metrics, add)
    }
}

impl Drop for Gauge<'_> {
    fn drop(&mut self) {
        (self.1)(self.0, -1);
    }
}

impl Admission {
    pub(super) fn new(max_concurrent: usize, max_queue: usize, metrics: Arc<Metrics>) -> Admission {
        let max_concurrent = max_concurrent.max(1);
        Admission {
            slots: Arc::new(Semaphore::new(max_concurrent)),
            max_concurrent,
            waiting: AtomicUsize::new(0),
            max_queue,
            metrics,
        }
    }

    /// A slot, once one is free; refused at once when the waiting line is full. Taken before any
    /// of the request's work or buffering (an upload is read only once admitted).
    pub(super) async fn admit(&self) -> Result<Admitted, Status> {
        let permit = match self.slots.clone().try_acquire_owned() {
            Ok(p) => p,
            Err(_) => {
                let waiting = self.waiting.fetch_add(1, Ordering::SeqCst);
                if waiting >= self.max_queue {
                    self.waiting.fetch_sub(1, Ordering::SeqCst);
                    self.metrics.add_rejected();
                    return Err(Status::resource_exhausted(format!(
                        "server busy: {} requests running and {} queued; retry later",
                        self.max_concurrent, self.max_queue
                    )));
                }
                // The waiting count is released however this future ends (dropped while queued too).
                struct Leave<'a>(&'a AtomicUsize);
                impl Drop for Leave<'_> {
                    fn drop(&mut self) {
                        self.0.fetch_sub(1, Ordering::SeqCst);
                    }
                }
                let _leave = Leave(&self.waiting);
                let _queued = Gauge::enter(&self.metrics, Metrics::add_queued);
                self.slots.clone().acquire_owned().await.map_err(|_| Status::unavailable("shutting down"))?
            }
        };
        Ok(Admitted { permit, metrics: self.metrics.clone() })
    }

    /// [`Admission::admit`], then [`Admitted::run`].
    pub(super) async fn run<T: Send + 'static>(
        &self,
        work: impl FnOnce(Arc<AtomicBool>) -> Result<T, Status> + Send + 'static,
    ) -> Result<T, Status> {
        self.admit().await?.run(work).await
    }
}

/// A held slot.
pub(super) struct Admitted {
    permit: OwnedSemaphorePermit,
    metrics: Arc<Metrics>,
}

impl Admitted {
    /// Runs `work` on a blocking thread in this slot, with a cancel flag that is raised if this
    /// future is dropped first. The slot is held until the work really ends.
    pub(super) async fn run<T: Send + 'static>(
        self,
        work: impl FnOnce(Arc<AtomicBool>) -> Result<T, Status> + Send + 'static,
    ) -> Result<T, Status> {
        let cancel = Arc::new(AtomicBool::new(false));
        let mut guard = CancelOnDrop(cancel.clone(), false);
        let Admitted { permit, metrics } = self;
        let handle = tokio::task::spawn_blocking(move || {
            let _permit = permit;
            let _in_flight = Gauge::enter(&metrics, Metrics::add_in_flight);
            work(cancel)
        });
        let result = handle.await.map_err(|e| {
            tracing::error!(error = %e, "worker panicked");
            Status::internal("internal error while processing the request")
        })?;
        guard.1 = true;
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gauge(metrics: &Metrics, name: &str) -> i64 {
        metrics.render().lines().find_map(|l| l.strip_prefix(&format!("{name} "))).unwrap().trim().parse().unwrap()
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_panicking_worker_gives_back_its_slot_and_its_gauge() {
        let metrics = Arc::new(Metrics::default());
        let admission = Admission::new(1, 0, metrics.clone());
        let status = admission.run(|_| -> Result<(), Status> { panic!("a bug in the work") }).await.unwrap_err();
        assert_eq!(status.code(), tonic::Code::Internal);
        assert_eq!(gauge(&metrics, "meshlod_in_flight"), 0, "the gauge was left up by the panic");
        // The only slot is free again.
        assert_eq!(admission.run(|_| Ok(7)).await.unwrap(), 7);
        assert_eq!(gauge(&metrics, "meshlod_queue_depth"), 0);
    }
}
