//! Progressive rendering: passes that continue each pixel's sample sequence, merged into one
//! film (Chan's parallel merge), until a sample count or a time budget is spent. A run can stop
//! after any pass and be resumed from the merged state it reached (references checkpoint it),
//! giving the same bits as a run never stopped. The pass loop takes its clock as a closure so
//! tests can drive it with a fake one.

use std::time::Instant;

use super::cpu_time::{cpu_seconds_between, process_cpu_seconds};
use crate::film::Film;
use crate::integrator::{render, Estimator, RenderOptions, RenderStats};
use crate::scene::Camera;

/// When to stop rendering passes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Exactly this many samples per pixel in total.
    Spp(u32),
    /// Passes until this many seconds have elapsed (at least one pass).
    Seconds(f64),
}

/// The clock a time budget is counted on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Clock {
    /// Wall-clock seconds.
    Wall,
    /// The process's CPU seconds, user and system, all threads: other jobs holding the cores
    /// do not move it.
    Cpu,
}

/// A reading of `clock` in seconds since this call.
fn stopwatch(clock: Clock) -> impl FnMut() -> f64 {
    let (start, cpu) = (Instant::now(), process_cpu_seconds());
    move || match clock {
        Clock::Cpu => cpu_seconds_between(cpu, process_cpu_seconds())
            .expect("CPU budgets are refused where the system gives no CPU time"),
        Clock::Wall => start.elapsed().as_secs_f64(),
    }
}

/// What the pass loop did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassCount {
    pub passes: u32,
    pub spp: u32,
}

/// Runs `pass(index, spp)` with passes of `pass_spp` samples (the last one of an spp budget
/// shorter) until the budget is spent. With a time budget, a pass starts only while
/// `elapsed()` is below the budget, so the time spent exceeds it by less than one pass.
pub fn run_passes(
    budget: Budget,
    pass_spp: u32,
    elapsed: impl FnMut() -> f64,
    mut pass: impl FnMut(u32, u32),
) -> PassCount {
    let start = PassCount { passes: 0, spp: 0 };
    continue_passes(budget, pass_spp, start, elapsed, |i, spp| {
        pass(i, spp);
        Flow::Continue
    })
}

/// Whether to render another pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    Continue,
    Stop,
}

/// [`run_passes`] continued from `done` (passes already rendered, e.g. by an interrupted run),
/// stopping early when `pass` returns [`Flow::Stop`]. Pass sizes do not depend on where a run
/// was interrupted: pass i always covers samples [i·pass_spp, (i+1)·pass_spp) of the budget.
pub fn continue_passes(
    budget: Budget,
    pass_spp: u32,
    mut done: PassCount,
    mut elapsed: impl FnMut() -> f64,
    mut pass: impl FnMut(u32, u32) -> Flow,
) -> PassCount {
    let pass_spp = pass_spp.max(1);
    loop {
        let spp = match budget {
            Budget::Spp(total) if done.spp >= total => break,
            Budget::Spp(total) => pass_spp.min(total - done.spp),
            Budget::Seconds(s) if done.passes > 0 && elapsed() >= s => break,
            Budget::Seconds(_) => pass_spp,
        };
        let flow = pass(done.passes, spp);
        done.passes += 1;
        done.spp += spp;
        if flow == Flow::Stop {
            break;
        }
    }
    done
}

/// A progressive render's merged result.
pub struct Progressive {
    pub film: Film,
    pub stats: RenderStats,
    pub count: PassCount,
    /// Wall-clock seconds of all passes.
    pub seconds: f64,
}

/// Renders passes of `pass_spp` and merges them; `on_pass(count_so_far, elapsed_seconds)` is
/// called after each pass (for progress display). Every pass keeps the seed and starts at
/// camera sample `opts.first_sample` + the samples already rendered, so the passes draw
/// distinct points: with the independent, Halton and Sobol samplers the merged film is
/// exactly one render of the total spp; stratified and LHS stratify each pass on its own.
pub fn render_progressive(
    estimator: &Estimator,
    camera: &Camera,
    opts: &RenderOptions,
    budget: Budget,
    clock: Clock,
    pass_spp: u32,
    mut on_pass: impl FnMut(PassCount, f64),
) -> Progressive {
    let on_pass = |p: &Progressive| {
        on_pass(p.count, p.seconds);
        Flow::Continue
    };
    progressive(
        estimator,
        camera,
        opts,
        (budget, clock),
        pass_spp,
        None,
        on_pass,
    )
}

/// [`render_progressive`] continued from `from` (the state an interrupted run saved after a
/// pass, or None to start afresh), calling `after_pass` with the merged state after every pass
/// and stopping early when it returns [`Flow::Stop`]. The passes continue each pixel's sample
/// sequence and are merged in the same order, so a run resumed from the state after pass i is
/// bit-identical to one never interrupted. Seconds add up over the runs (a time budget counts
/// them all).
pub fn resume_progressive(
    estimator: &Estimator,
    camera: &Camera,
    opts: &RenderOptions,
    budget: Budget,
    pass_spp: u32,
    from: Option<Progressive>,
    after_pass: impl FnMut(&Progressive) -> Flow,
) -> Progressive {
    let limit = (budget, Clock::Wall);
    progressive(estimator, camera, opts, limit, pass_spp, from, after_pass)
}

/// [`resume_progressive`] with a time budget counted on `clock`. A run resumed from an earlier
/// one adds that one's seconds only to a wall-clock budget: they are wall seconds.
fn progressive(
    estimator: &Estimator,
    camera: &Camera,
    opts: &RenderOptions,
    (budget, clock): (Budget, Clock),
    pass_spp: u32,
    from: Option<Progressive>,
    mut after_pass: impl FnMut(&Progressive) -> Flow,
) -> Progressive {
    let (mut wall, mut spent) = (stopwatch(Clock::Wall), stopwatch(clock));
    let before = from.as_ref().map_or(0.0, |p| p.seconds);
    let spent_before = if clock == Clock::Wall { before } else { 0.0 };
    let done = from
        .as_ref()
        .map_or(PassCount { passes: 0, spp: 0 }, |p| p.count);
    let mut state = from;
    continue_passes(
        budget,
        pass_spp,
        done,
        || spent_before + spent(),
        |_, spp| {
            let so_far = state.as_ref().map_or(0, |p| p.count.spp);
            let pass_opts = RenderOptions {
                spp,
                first_sample: opts.first_sample + so_far as u64,
                ..*opts
            };
            let (film, stats) = render(estimator, camera, &pass_opts);
            let p = match &mut state {
                None => state.insert(Progressive {
                    film,
                    stats,
                    count: PassCount { passes: 0, spp: 0 },
                    seconds: 0.0,
                }),
                Some(p) => {
                    p.film.merge(&film);
                    p.stats.add(&stats);
                    p
                }
            };
            p.count.passes += 1;
            p.count.spp += spp;
            p.seconds = before + wall();
            after_pass(p)
        },
    );
    state.expect("a fresh run renders at least one pass")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// Across a sleep the wall clock counts the sleep, and the CPU clock no more than the
    /// process's CPU time read around it (other tests' threads may add to that; run alone, it
    /// is near 0, and a CPU clock that counted wall seconds fails).
    #[cfg(unix)]
    #[test]
    fn the_cpu_clock_counts_cpu_time_not_a_sleep() {
        let before = process_cpu_seconds().unwrap();
        let (mut wall, mut cpu) = (stopwatch(Clock::Wall), stopwatch(Clock::Cpu));
        std::thread::sleep(std::time::Duration::from_millis(300));
        let (wall, cpu) = (wall(), cpu());
        let around = process_cpu_seconds().unwrap() - before;
        assert!(wall >= 0.3, "wall {wall}");
        assert!(0.0 <= cpu && cpu <= around, "cpu {cpu}, process {around}");
    }

    /// Drives the loop with a fake clock where every pass costs `cost` seconds.
    fn fake_run(budget: Budget, pass_spp: u32, cost: f64) -> (PassCount, f64) {
        let clock = Cell::new(0.0);
        let count = run_passes(
            budget,
            pass_spp,
            || clock.get(),
            |_, _| clock.set(clock.get() + cost),
        );
        (count, clock.get())
    }

    #[test]
    fn time_budget_is_spent_within_one_pass() {
        // 0.25 s passes: a 2 s budget takes exactly 8, a 2.1 s budget needs a 9th.
        let (c, spent) = fake_run(Budget::Seconds(2.0), 1, 0.25);
        assert_eq!((c.passes, c.spp), (8, 8));
        assert_eq!(spent, 2.0);
        let (c, spent) = fake_run(Budget::Seconds(2.1), 4, 0.25);
        assert_eq!((c.passes, c.spp), (9, 36));
        assert!((2.1..2.1 + 0.25).contains(&spent));
        // A pass longer than the whole budget still renders once.
        let (c, _) = fake_run(Budget::Seconds(0.1), 1, 5.0);
        assert_eq!(c.passes, 1);
        // Over many budgets and costs: never short, never more than one pass over.
        for budget in [0.5, 1.0, 3.3, 10.0] {
            for cost in [0.01, 0.07, 0.3, 1.1] {
                let (c, spent) = fake_run(Budget::Seconds(budget), 1, cost);
                assert!(spent >= budget && spent < budget + cost, "{budget} {cost}");
                assert_eq!(c.passes as f64, (spent / cost).round());
            }
        }
    }

    #[test]
    fn spp_budget_renders_exactly_the_requested_samples() {
        let mut sizes = Vec::new();
        let c = run_passes(Budget::Spp(37), 16, || 0.0, |i, spp| sizes.push((i, spp)));
        assert_eq!(sizes, vec![(0, 16), (1, 16), (2, 5)]);
        assert_eq!((c.passes, c.spp), (3, 37));
    }

    #[test]
    fn stopped_and_continued_passes_are_the_passes_of_one_run() {
        let sizes = std::cell::RefCell::new(Vec::new());
        let record = |i, spp| {
            sizes.borrow_mut().push((i, spp));
            if i == 1 {
                Flow::Stop
            } else {
                Flow::Continue
            }
        };
        let start = PassCount { passes: 0, spp: 0 };
        let c = continue_passes(Budget::Spp(37), 16, start, || 0.0, record);
        assert_eq!((c.passes, c.spp), (2, 32));
        let c = continue_passes(Budget::Spp(37), 16, c, || 0.0, record);
        assert_eq!((c.passes, c.spp), (3, 37));
        assert_eq!(*sizes.borrow(), vec![(0, 16), (1, 16), (2, 5)]);
        // Continued after the budget is spent: no pass.
        let c = continue_passes(Budget::Spp(37), 16, c, || 0.0, record);
        assert_eq!((c.passes, c.spp, sizes.borrow().len()), (3, 37, 3));
    }
}
