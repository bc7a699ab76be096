//! Chunk workers: the threads that run chunk builds and extractions.
//!
//! The core splits one chunk's work with rayon (sampling rows, Hermite data,
//! tree halves, contouring). Run from a thread of Bevy's task pools, every split
//! hands its pieces to rayon's global threads and blocks the calling thread until
//! they are done; run from rayon's own threads, a thread waiting for a piece
//! steals whole other chunks, which then have to finish before it can go on.
//! Either way the cores idle: a horizon's first load (232 chunks) kept 2 cores
//! about 60-70% busy and took 5.0-6.2 s.
//!
//! [`ChunkWorkers`] instead keeps one single-thread rayon pool per worker, all
//! taking jobs from one queue in the order they were started (nearest the camera
//! first). Inside a worker the core's splits run in place, so each chunk is done
//! by one thread from start to end and the workers never wait for each other:
//! the same load keeps the cores about 90% busy and takes 3.3-3.7 s (numbers from
//! `cargo bench --bench frame -- horizon`, 2 cores). Many chunks are in flight
//! at once ([`KdContourSettings::max_tasks_in_flight`](crate::KdContourSettings)),
//! so the workers stay busy while there is work.
//!
//! The workers run at a lower priority ([`WORKER_NICE`], Linux) than the
//! threads that run the frame's systems, so meshing never keeps a frame waiting
//! for a core.

use bevy::tasks::{AsyncComputeTaskPool, Task};

/// The niceness of a worker thread (Linux): 10 of 19, so a core the frame's
/// threads want is theirs at once while the workers keep every idle core busy.
pub const WORKER_NICE: i32 = 10;

/// Lowers the calling thread's scheduling priority to [`WORKER_NICE`]. On Linux
/// a niceness is each thread's own; elsewhere nothing changes.
fn lower_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: `setpriority` only reads its integer arguments; `who` 0 is the
    // calling thread on Linux. A refusal (a sandbox) leaves the priority as is.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, WORKER_NICE);
    }
}

/// One queued job.
type Job = Box<dyn FnOnce() + Send>;

/// A fixed set of worker threads taking chunk jobs from one queue. Dropping it
/// lets the workers finish the jobs already queued, then their threads end.
pub struct ChunkWorkers {
    queue: async_channel::Sender<Job>,
    wanted: usize,
    // Held so the pools (and their threads) live as long as the queue.
    _pools: Vec<rayon::ThreadPool>,
}

impl ChunkWorkers {
    /// Starts `threads` workers (0: one per core the system reports).
    pub fn new(wanted: usize) -> Self {
        let threads = match wanted {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        };
        let (queue, jobs) = async_channel::unbounded::<Job>();
        let _pools = (0..threads)
            .map(|i| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .thread_name(move |_| format!("kdcontour-chunks-{i}"))
                    .start_handler(|_| lower_priority())
                    .build()
                    .expect("the system refused a chunk worker thread");
                let jobs = jobs.clone();
                pool.spawn(move || {
                    while let Ok(job) = jobs.recv_blocking() {
                        job();
                    }
                });
                pool
            })
            .collect();
        ChunkWorkers {
            queue,
            wanted,
            _pools,
        }
    }

    /// The thread count asked for (0: one per core).
    pub fn wanted(&self) -> usize {
        self.wanted
    }

    /// Queues `work` and returns a task of [`AsyncComputeTaskPool`] that waits for
    /// it, so it is polled and collected like any task. Dropping the task before a
    /// worker takes `work` skips it (once the pool has dropped the task's future,
    /// right after); a panic in `work` resumes in the task.
    pub fn run<T: Send + 'static>(&self, work: impl FnOnce() -> T + Send + 'static) -> Task<T> {
        let (done, out) = async_channel::bounded(1);
        let job: Job = Box::new(move || {
            // Nobody waits for it any more: its task was dropped.
            if done.is_closed() {
                return;
            }
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
            let _ = done.send_blocking(result);
        });
        // Queued now, not when the task is first polled, so jobs keep the order
        // they were started in.
        let queued = self.queue.try_send(job).is_ok();
        AsyncComputeTaskPool::get().spawn(async move {
            assert!(queued, "the chunk workers' queue is closed");
            match out.recv().await {
                Ok(Ok(value)) => value,
                Ok(Err(panic)) => std::panic::resume_unwind(panic),
                // A job only skips itself once this task is dropped.
                Err(_) => unreachable!("a chunk job ended without its result"),
            }
        })
    }
}

/// Drops `garbage` on a task thread: freeing many meshes or trees costs the
/// main thread milliseconds.
pub(crate) fn drop_elsewhere<T: Send + 'static>(garbage: T) {
    AsyncComputeTaskPool::get()
        .spawn(async move { drop(garbage) })
        .detach();
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::tasks::{block_on, TaskPool};

    fn pool() {
        AsyncComputeTaskPool::get_or_init(TaskPool::new);
    }

    #[test]
    fn jobs_run_on_the_workers_and_return_their_results() {
        pool();
        let workers = ChunkWorkers::new(2);
        assert_eq!(workers._pools.len(), 2, "one single-thread pool per worker");
        let tasks: Vec<_> = (0..16u64)
            .map(|i| {
                workers.run(move || {
                    // The core's rayon splits run in place on a worker.
                    assert_eq!(rayon::current_num_threads(), 1);
                    let name = std::thread::current().name().map(str::to_owned);
                    (i * i, name)
                })
            })
            .collect();
        for (i, t) in tasks.into_iter().enumerate() {
            let (sq, name) = block_on(t);
            assert_eq!(sq, (i * i) as u64);
            assert!(name.is_some_and(|n| n.starts_with("kdcontour-chunks-")));
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn workers_run_below_the_frame_threads_priority() {
        pool();
        // SAFETY: `getpriority` reads its integer arguments only.
        let niceness = || unsafe { libc::getpriority(libc::PRIO_PROCESS, 0) };
        let ours = niceness();
        let workers = ChunkWorkers::new(1);
        // A thread may always raise its niceness, never lower it unprivileged:
        // a test run already nicer than the workers' keeps its own.
        assert_eq!(block_on(workers.run(niceness)), WORKER_NICE.max(ours));
        assert_eq!(niceness(), ours, "the calling thread keeps its priority");
    }

    #[test]
    fn a_panic_in_a_job_resumes_in_its_task_and_the_worker_goes_on() {
        pool();
        let workers = ChunkWorkers::new(1);
        let bad = workers.run(|| -> u32 { panic!("boom") });
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| block_on(bad)));
        let message = caught.expect_err("the panic reaches the task");
        assert_eq!(message.downcast_ref::<&str>(), Some(&"boom"));
        assert_eq!(block_on(workers.run(|| 7)), 7);
    }

    #[test]
    fn a_dropped_task_skips_its_job() {
        pool();
        let workers = ChunkWorkers::new(1);
        let (gate_tx, gate_rx) = std::sync::mpsc::channel::<()>();
        // The one worker waits on the gate, so the next job stays queued.
        let blocker = workers.run(move || gate_rx.recv().unwrap());
        let ran = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = ran.clone();
        drop(workers.run(move || flag.store(true, std::sync::atomic::Ordering::SeqCst)));
        // The pool drops a cancelled task's future (and with it the job's
        // receiver) on one of its threads, soon after the drop.
        std::thread::sleep(std::time::Duration::from_millis(200));
        gate_tx.send(()).unwrap();
        block_on(blocker);
        // The queue is FIFO and one worker runs it: the skipped job is past.
        block_on(workers.run(|| ()));
        assert!(!ran.load(std::sync::atomic::Ordering::SeqCst));
    }
}
