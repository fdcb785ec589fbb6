//! The kind of every error type a use case can return, as [`feedscope_app::error::kind_of`]
//! says it over an error's chain: what each front end maps to its exit code (the CLI: bad
//! input 2, anything else 1) or its exception. One value of each type; a wrapper over a cause
//! keeps bad input bad input.
use feedscope::ErrorKind;
use feedscope::ErrorKind::{BadInput, Internal, Io};
use feedscope_io::axis::AxisFileError;
use feedscope_io::friction_csv::FrictionCsvError;
use feedscope_io::stribeck_table::TableError;
use feedscope_store::{BackendError, BackendErrorKind, StoreError};
use std::io::{Error, ErrorKind as IoKind};

/// The kind of an error and its chain of sources, as a front end classifies it.
fn kind<E: std::error::Error + 'static>(e: E) -> ErrorKind {
    let top: &(dyn std::error::Error + 'static) = &e;
    feedscope::error::kind_of_chain(
        std::iter::successors(Some(top), |e| e.source()),
        feedscope_app::error::kind_of,
    )
}

fn io(k: IoKind) -> Error {
    Error::from(k)
}

fn bad_axis() -> feedscope::axis::AxisError {
    feedscope::axis::AxisParams::parse(
        "lead_mm = 1\n",
        feedscope::axis::ConfigFormat::Toml,
        "a.toml",
    )
    .unwrap_err()
}

#[test]
fn errors_of_the_maths_crate() {
    use feedscope::estimate::Direction;
    assert_eq!(kind(bad_axis()), BadInput);
    assert_eq!(
        kind(feedscope::dynamics::DynamicsError::MassNotPositiveDefinite { position_m: 0.1 }),
        BadInput
    );
    assert_eq!(
        kind(feedscope::estimate::EstimateError::BadSamplesPerLead),
        BadInput
    );
    assert_eq!(
        kind(feedscope::history::HistoryError::TooFewPoints { needed: 5, got: 2 }),
        BadInput
    );
    assert_eq!(
        kind(feedscope::ident::IdentError::NotIdentifiable {
            reason: "no reversal".into()
        }),
        BadInput
    );
    assert_eq!(
        kind(feedscope::lugre::LuGreError::TooFewPoints {
            points: 1,
            needed: 8
        }),
        BadInput
    );
    assert_eq!(kind(feedscope::map::MapError::NoStrokes), BadInput);
    assert_eq!(
        kind(feedscope::nc::NcError {
            source_name: "p.nc".into(),
            line: 3,
            message: "G999".into()
        }),
        BadInput
    );
    assert_eq!(
        kind(feedscope::order::OrderError::NonFinite { index: 4 }),
        BadInput
    );
    // A failed FFT plan is not the input's fault, alone or under a profile fit.
    assert_eq!(
        kind(feedscope::order::OrderError::Fft("plan".into())),
        Internal
    );
    assert_eq!(
        kind(feedscope::profile::ProfileError::Spectrum(
            feedscope::order::OrderError::Fft("plan".into())
        )),
        Internal
    );
    assert_eq!(
        kind(feedscope::plan::PlanError::FeedTooHigh {
            feed_mm_min: 9e4,
            limit_mm_min: 3e4
        }),
        BadInput
    );
    assert_eq!(
        kind(feedscope::profile::ProfileError::RankDeficient { column: 1 }),
        BadInput
    );
    assert_eq!(
        kind(feedscope::sim::SimError::Diverged { time_s: 1.0 }),
        BadInput
    );
    assert_eq!(
        kind(feedscope::spline::SplineError::TooFewKnots(1)),
        BadInput
    );
    assert_eq!(kind(feedscope::stribeck::StribeckError::NoMotion), BadInput);
    assert_eq!(
        kind(feedscope::study::StudyError::OneFeed {
            direction: Direction::Forward,
            feed_mm_min: 100.0
        }),
        BadInput
    );
}

/// A missing file is the user's input; a file that cannot be read for another reason is not.
#[test]
fn errors_of_the_readers() {
    let trace_io = |k| feedscope_io::trace::TraceError::Io {
        source_name: "t.csv".into(),
        error: io(k),
    };
    assert_eq!(kind(trace_io(IoKind::NotFound)), BadInput);
    assert_eq!(kind(trace_io(IoKind::PermissionDenied)), Io);
    assert_eq!(
        kind(feedscope_io::trace::TraceError::Empty {
            source_name: "t.csv".into()
        }),
        BadInput
    );
    let import_io = |k| feedscope_io::import::ImportError::Io {
        source_name: "s.log".into(),
        error: io(k),
    };
    assert_eq!(kind(import_io(IoKind::NotFound)), BadInput);
    assert_eq!(kind(import_io(IoKind::PermissionDenied)), Io);
    assert_eq!(
        kind(feedscope_io::import::ImportError::BadParam(
            "--rate-hz".into()
        )),
        BadInput
    );

    let read = |k| AxisFileError::Read {
        source_name: "a.toml".into(),
        error: io(k),
    };
    assert_eq!(kind(read(IoKind::NotFound)), BadInput);
    assert_eq!(kind(read(IoKind::PermissionDenied)), Io);
    assert_eq!(kind(AxisFileError::from(bad_axis())), BadInput);

    let csv_read = |k| FrictionCsvError::Read {
        source_name: "f.csv".into(),
        error: io(k),
    };
    assert_eq!(kind(csv_read(IoKind::NotFound)), BadInput);
    assert_eq!(kind(csv_read(IoKind::PermissionDenied)), Io);
    // A directory opens but does not read: the bare OS error, not the input's content.
    assert_ne!(
        kind(FrictionCsvError::Head(io(IoKind::IsADirectory))),
        BadInput
    );
    assert_eq!(
        kind(FrictionCsvError::BadDirection {
            source_name: "f.csv".into(),
            line: 2,
            text: "up".into(),
        }),
        BadInput
    );

    let table_read = |k| TableError::Read {
        source_name: "t.csv".into(),
        error: io(k),
    };
    assert_eq!(kind(table_read(IoKind::NotFound)), BadInput);
    assert_eq!(kind(table_read(IoKind::PermissionDenied)), Io);
    assert_eq!(
        kind(TableError::ZeroFeed {
            source_name: "t.csv".into(),
            line: 3,
        }),
        BadInput
    );
    assert_eq!(
        kind(TableError::BadEfficiency { efficiency: 2.0 }),
        BadInput
    );
}

/// A damaged or foreign database and an unusable address are the user's; a backend failure
/// or a permission problem is not.
#[test]
fn errors_of_the_store() {
    assert_eq!(kind(StoreError::NoSuchTest(7)), BadInput);
    assert_eq!(
        kind(StoreError::Corrupt {
            path: "h.db".into(),
            detail: "page 3".into()
        }),
        BadInput
    );
    assert_eq!(kind(StoreError::Io(io(IoKind::PermissionDenied))), Io);
    assert_eq!(
        kind(StoreError::ForeignSchema {
            path: "postgres://u@h/db".into(),
            schema: "public".into(),
            tables: 3,
            example: "invoices".into()
        }),
        BadInput
    );
    assert_eq!(
        kind(StoreError::BadAddress {
            path: "postgres://u@h/db".into(),
            detail: "TLS is not supported yet".into()
        }),
        BadInput
    );
    let backend = |k| StoreError::Backend(BackendError::new(k, "engine says no"));
    assert_eq!(kind(backend(BackendErrorKind::NotADatabase)), BadInput);
    assert_ne!(kind(backend(BackendErrorKind::Other)), BadInput);
    assert_eq!(
        kind(BackendError::new(BackendErrorKind::Corrupt, "damaged")),
        BadInput
    );
    assert_ne!(
        kind(StoreError::CommitUnknown {
            path: "postgres://u@h/db".into(),
            error: BackendError::new(BackendErrorKind::Other, "lost"),
        }),
        BadInput
    );
}

/// The layer's own errors, foreign parsers' errors and plain OS errors.
#[test]
fn errors_of_the_app_and_foreign_types() {
    assert_eq!(
        kind(feedscope_app::AppError::bad_input(
            "--segments must be at least 1"
        )),
        BadInput
    );
    assert_eq!(
        kind(feedscope_app::AppError::invalid(
            "segments",
            "must be at least 1"
        )),
        BadInput
    );
    assert_eq!(
        kind(toml::from_str::<toml::Table>("= 1").unwrap_err()),
        BadInput
    );
    assert_eq!(kind(serde_json::from_str::<u8>("x").unwrap_err()), BadInput);
    assert_eq!(kind(io(IoKind::NotFound)), BadInput);
    assert_eq!(kind(io(IoKind::PermissionDenied)), Io);
    // Bad input anywhere in the chain wins over what wraps it.
    let wrapped = feedscope_app::AppError::caused(
        Io,
        "writing out/stribeck.json",
        feedscope::stribeck::StribeckError::NoMotion,
    );
    assert_eq!(kind(wrapped), BadInput);
}
