//! Convergence sweeps: every problem of a population calibrated from the default start and
//! compared with the same problem started from the truth.

/// How one problem of a sweep ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// At the true minimum (within the sweep's tolerance).
    AtMinimum,
    /// The generator could not produce the draw (e.g. the board outside a camera's image).
    NotGenerated,
    /// The data does not determine the answer even from the truth (and the default start
    /// refused it too, where the test checks that).
    NotDetermined,
    /// The default start was refused: what and why.
    Refused(String),
    /// The solver stopped before converging: what and how.
    IterationLimit(String),
    /// Converged above the true minimum: what and the two RMS values.
    Above(String),
}

/// The outcomes of a sweep, counted.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tally {
    /// Problems at the true minimum.
    pub at_minimum: usize,
    /// Draws the generator could not produce.
    pub not_generated: usize,
    /// Problems the data does not determine.
    pub not_determined: usize,
    /// Refusals of the default start.
    pub refused: Vec<String>,
    /// Stops before convergence.
    pub iteration_limit: Vec<String>,
    /// Results above the true minimum.
    pub above: Vec<String>,
}

impl Tally {
    /// Counts one outcome.
    pub fn add(&mut self, outcome: Outcome) {
        match outcome {
            Outcome::AtMinimum => self.at_minimum += 1,
            Outcome::NotGenerated => self.not_generated += 1,
            Outcome::NotDetermined => self.not_determined += 1,
            Outcome::Refused(s) => self.refused.push(s),
            Outcome::IterationLimit(s) => self.iteration_limit.push(s),
            Outcome::Above(s) => self.above.push(s),
        }
    }

    /// Adds another tally's counts.
    pub fn merge(&mut self, other: Tally) {
        self.at_minimum += other.at_minimum;
        self.not_generated += other.not_generated;
        self.not_determined += other.not_determined;
        self.refused.extend(other.refused);
        self.iteration_limit.extend(other.iteration_limit);
        self.above.extend(other.above);
    }

    /// Every problem counted.
    pub fn total(&self) -> usize {
        self.at_minimum
            + self.not_generated
            + self.not_determined
            + self.refused.len()
            + self.iteration_limit.len()
            + self.above.len()
    }

    /// The failures (refused, iteration limit, above), one line each.
    pub fn failures(&self) -> Vec<&str> {
        self.refused
            .iter()
            .chain(&self.iteration_limit)
            .chain(&self.above)
            .map(String::as_str)
            .collect()
    }

    /// One line of counts, then each failure indented: what a sweep prints
    /// (`cargo test -- --nocapture` shows it).
    pub fn report(&self, what: &str) -> String {
        let mut out = format!(
            "{} {what} ({} not generated): {} at the minimum, {} not determined from the truth, {} refused, {} iteration limit, {} above",
            self.total(),
            self.not_generated,
            self.at_minimum,
            self.not_determined,
            self.refused.len(),
            self.iteration_limit.len(),
            self.above.len()
        );
        for line in self.failures() {
            out.push_str("\n  ");
            out.push_str(line);
        }
        out
    }
}

/// Runs `problem(seed)` for every seed of `0..problems`, split over two scoped threads (the
/// machines the suite runs on have two cores), and tallies the outcomes.
pub fn sweep(problems: u64, problem: impl Fn(u64) -> Outcome + Sync) -> Tally {
    let half = problems / 2;
    let run = |seeds: std::ops::Range<u64>| {
        let mut tally = Tally::default();
        for seed in seeds {
            tally.add(problem(seed));
        }
        tally
    };
    let [mut a, b] = std::thread::scope(|s| {
        let first = s.spawn(|| run(0..half));
        let second = s.spawn(|| run(half..problems));
        [first.join().unwrap(), second.join().unwrap()]
    });
    a.merge(b);
    a
}

/// The reference calibration, started from the truth; or [`Outcome::NotDetermined`] when the
/// data does not determine the answer even from there, after checking that the default start
/// refuses it as well (`default_refuses`: a problem without an answer must not be answered).
/// Any other failure of the truth start means the test itself is broken: panics, naming `what`.
pub fn reference_from_truth<R, E: std::fmt::Display>(
    what: &str,
    truth: Result<R, E>,
    default_refuses: impl FnOnce() -> bool,
) -> Result<R, Outcome> {
    match truth {
        Ok(reference) => Ok(reference),
        Err(e) if e.to_string().contains("not determined") => {
            assert!(
                default_refuses(),
                "{what}: accepted an undetermined problem"
            );
            Err(Outcome::NotDetermined)
        }
        Err(e) => panic!("{what}: the truth start fails: {e}"),
    }
}

/// A finished calibration in the form [`judge`] takes: its RMS with `Ok(())` when its solve
/// converged, or with `Err(termination)` (the reason it stopped) when it did not.
pub fn ended<T>(rms: f64, converged: bool, termination: T) -> (f64, Result<(), T>) {
    (rms, if converged { Ok(()) } else { Err(termination) })
}

/// Classifies a calibration from the default start against the reference (the truth start):
/// refused on an error, iteration limit when it did not converge, above when its RMS exceeds
/// `reference_rms + tolerance` (both over the same points), else at the minimum. `what`
/// describes the problem in the failure lines.
pub fn judge<E: std::fmt::Display, T: std::fmt::Display>(
    what: &str,
    result: Result<(f64, Result<(), T>), E>,
    reference_rms: f64,
    tolerance: f64,
) -> Outcome {
    match result {
        Err(e) => Outcome::Refused(format!("{what}: {e}")),
        Ok((_, Err(termination))) => Outcome::IterationLimit(format!("{what}: {termination}")),
        Ok((rms, Ok(()))) if rms.is_nan() || rms > reference_rms + tolerance => {
            Outcome::Above(format!("{what}: {rms} vs {reference_rms}"))
        }
        Ok(_) => Outcome::AtMinimum,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_truth_reference_separates_undetermined_data_from_broken_tests() {
        let ok: Result<f64, String> = Ok(0.5);
        assert_eq!(reference_from_truth("a", ok, || unreachable!()), Ok(0.5));
        let undetermined: Result<f64, String> = Err("pose of view 3 is not determined".into());
        assert_eq!(
            reference_from_truth("b", undetermined.clone(), || true),
            Err(Outcome::NotDetermined)
        );
        let accepted =
            std::panic::catch_unwind(|| reference_from_truth("c", undetermined, || false));
        assert!(
            accepted.is_err(),
            "an answered undetermined problem must fail the test"
        );
        let broken: Result<f64, String> = Err("board outside the image".into());
        assert!(std::panic::catch_unwind(|| reference_from_truth("d", broken, || true)).is_err());
    }

    #[test]
    fn judge_classifies_and_the_tally_counts_every_problem() {
        assert_eq!(ended(0.5, true, "limit"), (0.5, Ok(())));
        assert_eq!(ended(0.5, false, "limit"), (0.5, Err("limit")));
        let ok = |rms: f64| Ok::<_, String>((rms, Ok::<(), String>(())));
        assert_eq!(judge("p", ok(1.0), 1.0, 1e-5), Outcome::AtMinimum);
        assert_eq!(judge("p", ok(0.9), 1.0, 1e-5), Outcome::AtMinimum);
        assert!(matches!(judge("p", ok(1.1), 1.0, 1e-5), Outcome::Above(_)));
        assert!(matches!(
            judge("p", ok(f64::NAN), 1.0, 1e-5),
            Outcome::Above(_)
        ));
        let refused: Result<(f64, Result<(), String>), _> = Err("no".to_string());
        assert_eq!(
            judge("p", refused, 1.0, 1e-5),
            Outcome::Refused("p: no".into())
        );
        let limit = Ok::<_, String>((1.0, Err("iteration limit".to_string())));
        assert!(matches!(
            judge("p", limit, 1.0, 1e-5),
            Outcome::IterationLimit(_)
        ));
        let tally = sweep(7, |seed| match seed % 3 {
            0 => Outcome::AtMinimum,
            1 => Outcome::NotGenerated,
            _ => Outcome::Above(format!("seed {seed}")),
        });
        assert_eq!(tally.total(), 7);
        assert_eq!(
            (tally.at_minimum, tally.not_generated, tally.above.len()),
            (3, 2, 2)
        );
        assert!(tally.report("problems").contains("\n  seed 2"));
    }
}
