//! CPU time of the whole process (user + system, every thread): the cost figure that holds
//! still when other jobs share the cores. Wall time stretches while a render's threads wait for
//! a core; CPU time counts only the time they ran. Read with getrusage(RUSAGE_SELF).

/// CPU seconds the process has used so far, user and system, all threads; None where the
/// system does not say (off Unix, or the call fails).
pub fn process_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        // SAFETY: getrusage writes one `rusage` into the zeroed struct it is given.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
            return None;
        }
        let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
        Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// CPU seconds used between two readings of [`process_cpu_seconds`], where both exist.
pub fn cpu_seconds_between(before: Option<f64>, after: Option<f64>) -> Option<f64> {
    Some(after? - before?)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    /// This thread's CPU seconds, from the kernel's per-thread clock: a reading independent of
    /// getrusage's per-process sums.
    fn thread_cpu_seconds() -> f64 {
        // SAFETY: clock_gettime writes one `timespec` into the zeroed struct it is given.
        let mut t: libc::timespec = unsafe { std::mem::zeroed() };
        assert_eq!(
            unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) },
            0
        );
        t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
    }

    /// Work done on this thread shows in the process's CPU seconds: at least the thread's own
    /// CPU clock's increase (less getrusage's microsecond rounding at both readings), which is
    /// itself positive.
    #[test]
    fn the_process_cpu_time_counts_a_threads_work() {
        let (process, thread) = (process_cpu_seconds().unwrap(), thread_cpu_seconds());
        let mut x = 0u64;
        for i in 0..30_000_000u64 {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(i));
        }
        std::hint::black_box(x);
        let thread = thread_cpu_seconds() - thread;
        let process = cpu_seconds_between(Some(process), process_cpu_seconds()).unwrap();
        assert!(thread > 0.0, "the thread's clock did not move");
        assert!(
            process >= thread - 2e-6,
            "process {process} s < thread {thread} s"
        );
    }
}
