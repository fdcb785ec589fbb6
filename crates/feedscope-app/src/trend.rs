//! The condition trend of an axis from the history store (docs/history.md): every indicator's
//! series against its baseline, the stroke tests' friction compared position by position with
//! their baseline, and the diagnosis in words.
//!
//! [`TrendOptions`] are the baseline and the detectors' settings, as a user gives them;
//! [`axis_trend`] finds the axis (given, or the only one of the machine), takes the thresholds
//! in force (the stored axis file's, each overridden by a thresholds file's) and gives the
//! [`AxisTrends`] report, the JSON layout of `history trend` and the model of the report page.
//! [`TrendRequest`] is `history trend` whole: the settings checked and the thresholds file read
//! before the store is opened, the machine found ([`resolve_machine`]), the trend made.
use std::collections::BTreeMap;
use std::path::PathBuf;

use feedscope::history::{
    DirectionChanges, IndicatorTrend, LocalParams, ProfileChanges, ProfileTest, Threshold,
};
use feedscope::study::TrendStudyParams;
use feedscope_store::{AxisSeries, Filter, Store, Stored, TestKind, TestRow};
use serde::{Deserialize, Serialize};

use crate::store::{Opener, StoreSpec};
use crate::{AppError, FrontEnd};

/// The baseline and the change detectors' settings (docs/history.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrendOptions {
    /// Baseline: mean and σ of the first N tests of each indicator; with a reference test
    /// marked, μ₀ is its value and σ the scatter of these N.
    pub baseline_tests: usize,
    /// Thresholds file (TOML): a `[thresholds]` table of indicator = { upper = .., lower = .. },
    /// each overriding the stored axis file's.
    pub thresholds: Option<PathBuf>,
    /// Stroke tests whose friction profiles form the baseline of the position-resolved
    /// comparison (the first N; at least 2, their scatter sets the limits).
    pub profile_baseline_tests: usize,
    /// Flag width of the position-resolved comparison, in σ of the baseline's own
    /// test-to-test scatter at each position.
    pub profile_limit_sigma: f64,
    /// Chance per test that any of the axis's component amplitudes raises a false alarm
    /// although nothing changed; in (0, 0.5).
    pub component_false_alarm: f64,
}

impl Default for TrendOptions {
    fn default() -> Self {
        let trend = TrendStudyParams::default();
        let local = LocalParams::default();
        Self {
            baseline_tests: trend.baseline_tests,
            thresholds: None,
            profile_baseline_tests: local.baseline_tests,
            profile_limit_sigma: local.k,
            component_false_alarm: trend.component_false_alarm_per_test,
        }
    }
}

impl TrendOptions {
    /// Check the settings without reading anything.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field in the front end's spelling.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        self.study_params(BTreeMap::new(), front).map(|_| ())
    }

    /// The study's settings with `thresholds` in force.
    ///
    /// # Errors
    /// As [`TrendOptions::validate`].
    pub fn study_params(
        &self,
        thresholds: BTreeMap<String, Threshold>,
        front: &dyn FrontEnd,
    ) -> Result<TrendStudyParams, AppError> {
        if self.profile_baseline_tests < 2 {
            return Err(AppError::invalid(
                "profile_baseline_tests",
                format!(
                    "{} {}: the profile baseline needs at least 2 stroke tests (their scatter \
                     sets the limits)",
                    front.name("profile_baseline_tests"),
                    self.profile_baseline_tests
                ),
            ));
        }
        if !(self.profile_limit_sigma.is_finite() && self.profile_limit_sigma > 0.0) {
            return Err(AppError::invalid(
                "profile_limit_sigma",
                format!(
                    "{} {}: must be a positive number of σ",
                    front.name("profile_limit_sigma"),
                    self.profile_limit_sigma
                ),
            ));
        }
        if !(self.component_false_alarm > 0.0 && self.component_false_alarm < 0.5) {
            return Err(AppError::invalid(
                "component_false_alarm",
                format!(
                    "{} {}: must be a probability in (0, 0.5), e.g. 0.001",
                    front.name("component_false_alarm"),
                    self.component_false_alarm
                ),
            ));
        }
        Ok(TrendStudyParams {
            baseline_tests: self.baseline_tests,
            thresholds,
            profiles: LocalParams {
                baseline_tests: self.profile_baseline_tests,
                k: self.profile_limit_sigma,
                ..LocalParams::default()
            },
            component_false_alarm_per_test: self.component_false_alarm,
            ..TrendStudyParams::default()
        })
    }

    /// The thresholds file's thresholds (none without a file).
    ///
    /// # Errors
    /// The reader's error naming the file and the key (an unknown indicator is bad input).
    pub fn file_thresholds(&self) -> Result<BTreeMap<String, Threshold>, AppError> {
        match &self.thresholds {
            None => Ok(BTreeMap::new()),
            Some(p) => feedscope_io::thresholds::read(p)
                .map_err(|e| AppError::from_error(e).for_field("thresholds")),
        }
    }
}

/// The trend of one axis from a store: `history trend` (and the report page's model).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrendRequest {
    /// Machine name; default: the only machine in the store ([`resolve_machine`]).
    pub machine: Option<String>,
    /// Axis name; default: the only axis of the machine.
    pub axis_name: Option<String>,
    /// The baseline and the detectors' settings.
    #[serde(flatten)]
    pub options: TrendOptions,
}

impl TrendRequest {
    /// Check the settings and read the thresholds file, then open the store `spec` with
    /// `opener` and make the trend ([`TrendRequest::trend`]): a bad setting or thresholds
    /// file is refused before any store is opened (or created).
    ///
    /// # Errors
    /// As [`TrendOptions::validate`], [`TrendOptions::file_thresholds`], [`Opener::open`] and
    /// [`TrendRequest::trend`].
    pub fn run(
        &self,
        spec: &StoreSpec,
        opener: &Opener,
        front: &dyn FrontEnd,
    ) -> Result<AxisTrends, AppError> {
        self.options.validate(front)?;
        let from_file = self.options.file_thresholds()?;
        let store = opener.open(spec)?;
        self.trend(&*store, from_file, front)
    }

    /// The trend of the request's axis in an open store, with `from_file` the thresholds
    /// file's thresholds ([`TrendOptions::file_thresholds`]).
    ///
    /// # Errors
    /// As [`resolve_machine`] and [`axis_trend`].
    pub fn trend(
        &self,
        store: &dyn Store,
        from_file: BTreeMap<String, Threshold>,
        front: &dyn FrontEnd,
    ) -> Result<AxisTrends, AppError> {
        let machine = resolve_machine(store, self.machine.as_deref(), front)?;
        axis_trend(
            store,
            &machine,
            self.axis_name.as_deref(),
            &self.options,
            from_file,
            front,
        )
    }
}

/// The trends of an axis and its diagnosis: `history trend --format json`.
#[derive(Debug, Clone, Serialize)]
pub struct AxisTrends {
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Tests of the axis in time order.
    pub tests: Vec<TestRow>,
    /// One per indicator with enough tests.
    pub trends: Vec<IndicatorTrend>,
    /// Indicators with too few tests for a baseline.
    pub skipped: Vec<String>,
    /// The stroke tests' friction compared with their baseline position by position.
    pub profiles: Option<ProfileChanges>,
    /// Diagnosis sentences.
    pub diagnosis: Vec<String>,
}

impl AxisTrends {
    /// True when any indicator is not `ok` (drifting, warning or alarm).
    pub fn needs_attention(&self) -> bool {
        self.trends
            .iter()
            .any(|x| x.status != feedscope::history::Status::Ok)
    }

    /// The worst status of the axis's indicators; `None` while no indicator has a baseline
    /// (no trend, so no status either way).
    pub fn worst_status(&self) -> Option<feedscope::history::Status> {
        self.trends.iter().map(|x| x.status).min()
    }

    /// The axis's trend in a few words, for a line of a live log or a fleet list: `ok`, the
    /// number of indicators not ok with the worst status, or `baseline not yet formed`.
    pub fn status_line(&self) -> String {
        let Some(worst) = self.worst_status() else {
            return "baseline not yet formed".into();
        };
        let bad = self
            .trends
            .iter()
            .filter(|x| x.status != feedscope::history::Status::Ok)
            .count();
        if bad == 0 {
            "ok".into()
        } else {
            format!("{bad} indicator(s) not ok ({})", worst.as_str())
        }
    }

    /// [`Outcome::Attention`](crate::Outcome) naming the indicators that are not `ok` (worst
    /// first), else [`Outcome::Done`](crate::Outcome): what `--fail-on-warning` ends with.
    pub fn outcome(&self) -> crate::Outcome {
        let mut bad: Vec<&IndicatorTrend> = self
            .trends
            .iter()
            .filter(|x| x.status != feedscope::history::Status::Ok)
            .collect();
        if bad.is_empty() {
            return crate::Outcome::Done;
        }
        bad.sort_by_key(|x| x.status);
        let names: Vec<String> = bad
            .iter()
            .map(|x| format!("{} {}", x.indicator.name(), x.status.as_str()))
            .collect();
        crate::Outcome::Attention(format!(
            "{} indicator(s) of {}/{} not ok: {}",
            bad.len(),
            self.machine,
            self.axis,
            names.join(", ")
        ))
    }
}

/// The trend of `machine`'s axis `axis` (or of its only axis): the thresholds of the stored
/// axis file, each overridden by the same key of `from_file` (the options' thresholds file,
/// [`TrendOptions::file_thresholds`], read by the caller before it opens the store).
///
/// # Errors
/// An unknown machine or axis (listing those stored, [`check_known`]); a machine with several
/// axes and none chosen; settings as [`TrendOptions::study_params`]; store errors.
pub fn axis_trend(
    store: &dyn Store,
    machine: &str,
    axis: Option<&str>,
    options: &TrendOptions,
    from_file: BTreeMap<String, Threshold>,
    front: &dyn FrontEnd,
) -> Result<AxisTrends, AppError> {
    options.validate(front)?;
    let axis = resolve_axis(store, machine, axis, front)?;
    let thresholds = with_axis_thresholds(store, machine, &axis, from_file)?;
    let params = options.study_params(thresholds, front)?;
    axis_trends(store, machine, &axis, &params)
}

/// A store error as it is, with its kind as the store says it.
fn store(e: feedscope_store::StoreError) -> AppError {
    AppError::from_error(e)
}

/// The thresholds in force: those of the axis file stored with the tests (`[thresholds]`),
/// each overridden by the same key of `from_file`.
///
/// # Errors
/// Store errors.
pub fn with_axis_thresholds(
    store_: &dyn Store,
    machine: &str,
    axis: &str,
    from_file: BTreeMap<String, Threshold>,
) -> Result<BTreeMap<String, Threshold>, AppError> {
    let mut out = BTreeMap::new();
    // Stored by `history add` from a validated axis file; one another version wrote in a
    // shape this one does not read carries no thresholds here.
    if let Some(p) = store_
        .axis_params(machine, axis)
        .map_err(store)?
        .and_then(Stored::into_read)
    {
        out = p.thresholds;
    }
    out.extend(from_file);
    Ok(out)
}

/// Trends of every indicator of an axis, from the series in the store.
///
/// # Errors
/// Bad input when no test of the axis is stored; the study's and the store's errors.
pub fn axis_trends(
    store_: &dyn Store,
    machine: &str,
    axis: &str,
    params: &TrendStudyParams,
) -> Result<AxisTrends, AppError> {
    let tests = store_
        .list(&Filter {
            machine: Some(machine.to_string()),
            axis: Some(axis.to_string()),
        })
        .map_err(store)?;
    if tests.is_empty() {
        return Err(AppError::bad_input(format!(
            "no tests stored for {machine} {axis}"
        )));
    }
    let reference = tests.iter().find(|t| t.reference).map(|t| t.id);
    let series = store_.series(machine, axis).map_err(store)?;
    let profiles = stroke_profiles(store_, &tests)?;
    let study = feedscope::study::axis_study(&series, reference, &profiles, params)
        .map_err(AppError::from_error)?;
    Ok(AxisTrends {
        machine: machine.to_string(),
        axis: axis.to_string(),
        tests,
        trends: study.trends,
        skipped: study.skipped,
        profiles: study.profiles,
        diagnosis: study.diagnosis,
    })
}

/// The position-grid friction profiles of the stroke tests, in time order, from their stored
/// curves; tests stored before the grid existed have none and are left out.
fn stroke_profiles(store_: &dyn Store, tests: &[TestRow]) -> Result<Vec<ProfileTest>, AppError> {
    let mut out = Vec::new();
    for t in tests.iter().filter(|t| t.kind == TestKind::Strokes) {
        let c = match store_.curves(t.id).map_err(store)? {
            None => continue,
            Some(Stored::Read(c)) => c,
            Some(Stored::Unread { reason, .. }) => {
                return Err(unread_curves(t.id, &reason));
            }
        };
        if c.grid.is_empty() {
            continue;
        }
        out.push(ProfileTest {
            test_id: t.id,
            time_s: t.time_s,
            profiles: c.grid,
        });
    }
    Ok(out)
}

/// The stored curves of test `id` do not read as this version's ([`Stored::Unread`]): an
/// error, as a profile comparison without one of its tests would compare the wrong ones.
pub(crate) fn unread_curves(id: i64, reason: &str) -> AppError {
    AppError::failed(format!(
        "the stored report curves of test {id} do not read as this version of feedscope's \
         ({reason}); written by another version? Use that version, or remove the test"
    ))
}

/// The machine a request without one means: what `history add` stores without a machine
/// name ([`crate::history::AddOptions`]'s default).
const DEFAULT_MACHINE: &str = "machine";

/// The machine `history trend` and the report look at: `given`, or without one the only
/// machine in the store (or, among several, the one named `machine`, what `history add`
/// stores when no machine is named).
///
/// # Errors
/// Bad input when the store holds no test (saying how to add one, [`FrontEnd::how_to_add`])
/// or several machines and none is `machine` (listing them, naming the `machine` field); store
/// errors.
pub fn resolve_machine(
    store_: &dyn Store,
    given: Option<&str>,
    front: &dyn FrontEnd,
) -> Result<String, AppError> {
    if let Some(m) = given {
        return Ok(m.to_string());
    }
    let mut machines: Vec<String> = store_
        .axes()
        .map_err(store)?
        .into_iter()
        .map(|a| a.machine)
        .collect();
    machines.sort_unstable();
    machines.dedup();
    match machines.as_slice() {
        [] => Err(AppError::bad_input(format!(
            "the database holds no tests yet; store one with {}",
            front.how_to_add()
        ))),
        [one] => Ok(one.clone()),
        many if many.iter().any(|m| m == DEFAULT_MACHINE) => Ok(DEFAULT_MACHINE.to_string()),
        many => Err(AppError::invalid(
            "machine",
            format!(
                "the database holds several machines ({}): choose one with {}",
                many.iter()
                    .map(|m| format!("{m:?}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                front.name("machine")
            ),
        )),
    }
}

/// The flag limit of a direction's position-resolved comparison in one number: the median
/// over the compared travel of K·σ(x)·√(1 + 1/n_m) (N); NaN when no position was compared.
pub fn median_limit_n(d: &DirectionChanges) -> f64 {
    let mut lim = d.limit_n.clone();
    lim.sort_by(f64::total_cmp);
    lim.get(lim.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The whole-travel limit of a direction, K_level·σ_a·√(1 + 1/n_m) in percent of the mean
/// baseline level m̄, with n_m = 1 against a reference test and the number of baseline tests
/// otherwise (docs/history.md); `level_k` is [`LocalParams::level_k`].
pub fn whole_travel_limit_percent(d: &DirectionChanges, level_k: f64) -> f64 {
    let n_m = if d.reference_id.is_some() {
        1.0
    } else {
        d.baseline_ids.len() as f64
    };
    100.0 * level_k * d.level_sigma * (1.0 + 1.0 / n_m).sqrt()
}

/// The axis name: given, or the only axis of the machine.
///
/// # Errors
/// As [`check_known`]; a machine with several axes and none given (naming the `axis_name`
/// field).
pub fn resolve_axis(
    store_: &dyn Store,
    machine: &str,
    axis: Option<&str>,
    front: &dyn FrontEnd,
) -> Result<String, AppError> {
    check_known(store_, machine, axis, front)?;
    if let Some(a) = axis {
        return Ok(a.to_string());
    }
    let tests = store_
        .list(&Filter {
            machine: Some(machine.to_string()),
            axis: None,
        })
        .map_err(store)?;
    let mut axes: Vec<&str> = tests.iter().map(|t| t.axis.as_str()).collect();
    axes.sort_unstable();
    axes.dedup();
    match axes.as_slice() {
        [one] => Ok(one.to_string()),
        [] => Err(AppError::bad_input(format!(
            "no tests stored for machine {machine:?}"
        ))),
        many => Err(AppError::invalid(
            "axis_name",
            format!(
                "machine {machine:?} has several axes ({}): choose one with {}",
                many.join(", "),
                front.name("axis_name")
            ),
        )),
    }
}

/// `"a" (3 tests)`.
fn one(a: &AxisSeries) -> String {
    format!(
        "{:?} ({} test{})",
        a.axis,
        a.tests,
        if a.tests == 1 { "" } else { "s" }
    )
}

/// Refuse a machine, or an axis of a machine, that the store does not hold, listing those it
/// does: the machines with their axes, or the machine's axes, saying which one is taken when
/// the field is not given ([`FrontEnd::default_machine`]). `Ok` when the names are known (or
/// `axis` is `None` and the machine is known).
///
/// # Errors
/// Bad input with that list, naming the field (`machine`, `axis_name`); an empty store says
/// how to add a test ([`FrontEnd::how_to_add`]); store errors.
pub fn check_known(
    store_: &dyn Store,
    machine: &str,
    axis: Option<&str>,
    front: &dyn FrontEnd,
) -> Result<(), AppError> {
    let all = store_.axes().map_err(store)?;
    if all.is_empty() {
        return Err(AppError::bad_input(format!(
            "the database holds no tests yet; store one with {}",
            front.how_to_add()
        )));
    }
    let mine: Vec<&AxisSeries> = all.iter().filter(|a| a.machine == machine).collect();
    if mine.is_empty() {
        let mut machines: Vec<String> = Vec::new();
        for a in &all {
            let axes: Vec<String> = all
                .iter()
                .filter(|b| b.machine == a.machine)
                .map(one)
                .collect();
            let line = format!("{:?} (axes {})", a.machine, axes.join(", "));
            if !machines.contains(&line) {
                machines.push(line);
            }
        }
        let only = &all[0].machine;
        let hint = if machines.len() > 1 {
            format!("; choose one with {}", front.name("machine"))
        } else if front.default_machine().is_none_or(|d| d == only) {
            format!(
                "; it is the only one, the default when {} is not given",
                front.name("machine")
            )
        } else {
            format!(
                "; it is the only one: give {}",
                front.spell("machine", only)
            )
        };
        return Err(AppError::invalid(
            "machine",
            format!(
                "no machine {machine:?} in the database; machines stored: {}{hint}",
                machines.join("; ")
            ),
        ));
    }
    match axis {
        Some(ax) if !mine.iter().any(|a| a.axis == ax) => {
            let hint = if mine.len() == 1 {
                format!(
                    "; it is the only one, the default when {} is not given",
                    front.name("axis_name")
                )
            } else {
                format!("; choose one with {}", front.name("axis_name"))
            };
            Err(AppError::invalid(
                "axis_name",
                format!(
                    "machine {machine:?} has no axis {ax:?}; axes stored: {}{hint}",
                    mine.iter().map(|a| one(a)).collect::<Vec<_>>().join(", ")
                ),
            ))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Quiet;
    use feedscope::ErrorKind;
    use feedscope_store::{IndicatorRow, NewTest, SqliteStore};

    /// A triangle test of `machine` `axis` on day `day` with a Coulomb friction.
    fn test(machine: &str, axis: &str, day: usize) -> NewTest {
        let time_s = 1.8e9 + day as f64 * 86_400.0;
        NewTest {
            machine: machine.into(),
            axis: axis.into(),
            axis_params: Stored::from_json("{}"),
            time_utc: feedscope_store::time::format_rfc3339(time_s),
            time_s,
            kind: TestKind::Triangle,
            source: format!("day{day}.csv"),
            content_sha256: format!("{machine}-{axis}-{day}"),
            program: None,
            reference: false,
            compensation_ref: None,
            identified: None,
            intervals: Vec::new(),
            components: Vec::new(),
            indicators: vec![IndicatorRow {
                name: "fc_n".into(),
                value: 100.0 + day as f64 % 3.0,
                std_error: Some(0.5),
                unit: "N".into(),
            }],
            curves: None,
        }
    }

    /// Without a machine: the only one, else the default name among several, else refused
    /// listing them; an empty store says how to add a test.
    #[test]
    fn the_machine_a_request_without_one_means() {
        let d = tempfile::tempdir().unwrap();
        let mut s = SqliteStore::open(&d.path().join("h.db")).unwrap();
        let e = resolve_machine(&s, None, &Quiet).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the database holds no tests yet; store one with a `history add` request"
        );
        s.add(&test("lathe", "Z", 0)).unwrap();
        assert_eq!(resolve_machine(&s, None, &Quiet).unwrap(), "lathe");
        assert_eq!(resolve_machine(&s, Some("mill"), &Quiet).unwrap(), "mill");
        s.add(&test("mill", "X", 0)).unwrap();
        let e = resolve_machine(&s, None, &Quiet).unwrap_err();
        assert_eq!(
            (e.kind(), e.field()),
            (ErrorKind::BadInput, Some("machine"))
        );
        assert_eq!(
            e.to_string(),
            "the database holds several machines (\"lathe\", \"mill\"): choose one with \
             `machine`"
        );
        s.add(&test(DEFAULT_MACHINE, "X", 0)).unwrap();
        assert_eq!(resolve_machine(&s, None, &Quiet).unwrap(), DEFAULT_MACHINE);
    }

    /// `history trend` whole: a bad setting or thresholds file is refused before the store
    /// is opened (no database made); otherwise the trend of the machine's only axis.
    #[test]
    fn a_trend_request_checks_before_it_opens() {
        let d = tempfile::tempdir().unwrap();
        let db = d.path().join("h.db");
        let spec = StoreSpec::Sqlite(db.clone());
        let mut bad = TrendRequest::default();
        bad.options.profile_limit_sigma = -1.0;
        let e = bad.run(&spec, &Opener::quiet(), &Quiet).unwrap_err();
        assert_eq!(e.field(), Some("profile_limit_sigma"));
        bad.options = TrendOptions {
            thresholds: Some(d.path().join("missing.toml")),
            ..TrendOptions::default()
        };
        let e = bad.run(&spec, &Opener::quiet(), &Quiet).unwrap_err();
        assert_eq!(
            (e.kind(), e.field()),
            (ErrorKind::BadInput, Some("thresholds"))
        );
        assert!(!db.exists(), "a refused request made a database");

        let mut s = SqliteStore::open(&db).unwrap();
        for day in 0..8 {
            s.add(&test("lathe", "Z", day)).unwrap();
        }
        drop(s);
        let t = TrendRequest::default()
            .run(&spec, &Opener::quiet(), &Quiet)
            .unwrap();
        assert_eq!(
            (t.machine.as_str(), t.axis.as_str(), t.tests.len()),
            ("lathe", "Z", 8)
        );
        assert_eq!(t.trends.len(), 1, "{:?}", t.skipped);
    }
}
