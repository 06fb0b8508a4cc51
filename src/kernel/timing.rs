//! Thread CPU time per phase of the steps ([`PhaseTimes`]), and the
//! stopwatch the step uses to fill it.

/// Thread CPU seconds spent in each phase of the steps timed so far (see
/// [`super::step_patches`]). The stress update runs inside the G2P pass that
/// computes the strain, so it is counted under `g2p`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Grid reset and particle-to-grid passes.
    pub p2g: f64,
    /// Grid updates and boundary conditions.
    pub grid: f64,
    /// Grid-to-particle passes (with the stress update).
    pub g2p: f64,
    /// Fused last passes (G2P of one step with the P2G of the next).
    pub fused: f64,
    /// Fused middle passes (a G2P pass with the P2G the scheme does next
    /// within the step: MUSL's velocity pass with its momentum re-map,
    /// USF's strain pass with its force scatter).
    pub mid: f64,
    /// Particle sorting.
    pub sort: f64,
    /// Steps timed.
    pub steps: u64,
}

impl PhaseTimes {
    /// Sum of all phases.
    pub fn total(&self) -> f64 {
        self.p2g + self.grid + self.g2p + self.fused + self.mid + self.sort
    }
}

/// CPU time of the calling thread, in seconds (`CLOCK_THREAD_CPUTIME_ID`):
/// unlike wall time it does not count the time other processes hold the
/// core, so timings on a shared machine stay comparable.
pub fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant
    // that every supported (POSIX) target provides.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return 0.0;
    }
    ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
}

/// A stopwatch that adds the thread CPU time since the last lap to a phase,
/// or does nothing when timing is off.
pub(crate) struct Laps<'a> {
    t: Option<(&'a mut PhaseTimes, f64)>,
}

impl<'a> Laps<'a> {
    /// Starts timing into `t` (or not, for `None`).
    pub(crate) fn new(t: Option<&'a mut PhaseTimes>) -> Laps<'a> {
        Laps {
            t: t.map(|t| (t, thread_cpu_seconds())),
        }
    }

    /// Adds the time since the last lap to the phase `f` selects.
    #[inline]
    pub(crate) fn lap(&mut self, f: impl FnOnce(&mut PhaseTimes) -> &mut f64) {
        if let Some((t, last)) = &mut self.t {
            let now = thread_cpu_seconds();
            *f(t) += now - *last;
            *last = now;
        }
    }

    /// Counts one more step timed (nothing when timing is off).
    #[inline]
    pub(crate) fn count_step(&mut self) {
        if let Some((t, _)) = &mut self.t {
            t.steps += 1;
        }
    }
}
