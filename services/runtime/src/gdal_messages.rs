//! GDAL's own error messages: routed to `tracing` once per process, and collected while a
//! [`capture_failures`] is active on the calling thread.
//!
//! GDAL reports many read failures only through its error handler, not through a return value: a
//! corrupted GeoPackage page ends a feature loop early ("database disk image is malformed"), an
//! unreadable geometry blob yields a feature without geometry ("Unable to read geometry"). Readers wrap
//! such loops in [`capture_failures`] and turn what was collected into a diagnostic that names the file,
//! layer and feature, instead of silently reading fewer features.
//!
//! GDAL calls the handler on the thread that raised the error, so a thread-local collector sees exactly
//! the messages of the work it wraps.

use std::cell::RefCell;

use gdal::errors::CplErrType;

thread_local! {
    static COLLECTED: RefCell<Option<Vec<String>>> = const { RefCell::new(None) };
}

/// Send GDAL's error printing to `tracing` (once per process), and to the active collector of the thread
/// for failures: failures otherwise come back as typed errors, so GDAL's duplicate lines on stderr would
/// only confuse users.
pub fn route_gdal_messages() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        gdal::config::set_error_handler(|class, code, message| {
            tracing::debug!(target: "gdal", ?class, code, message, "gdal message");
            if matches!(class, CplErrType::Failure | CplErrType::Fatal) {
                // `try_with`: during thread teardown the collector may already be gone.
                let _ = COLLECTED.try_with(|c| {
                    if let Ok(mut c) = c.try_borrow_mut()
                        && let Some(list) = c.as_mut()
                        && list.len() < MAX_MESSAGES
                    {
                        list.push(message.trim().to_owned());
                    }
                });
            }
        });
    });
}

/// Messages kept per capture: a loop that fails on every feature must not grow without bound.
const MAX_MESSAGES: usize = 64;

/// Run `work` and return what it returned with the GDAL failure messages raised on this thread meanwhile
/// (at most 64, in order). Captures nest: an inner capture takes its own messages, and the outer one
/// continues afterwards.
pub fn capture_failures<T>(work: impl FnOnce() -> T) -> (T, Vec<String>) {
    route_gdal_messages();
    let outer = COLLECTED.with(|c| c.replace(Some(Vec::new())));
    let result = work();
    let inner = COLLECTED.with(|c| c.replace(outer));
    (result, inner.unwrap_or_default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failures_raised_inside_a_capture_are_collected_and_nested_captures_keep_their_own() {
        // PROJ reports an unknown code through GDAL's error handler.
        let fail = |code| gdal::spatial_ref::SpatialRef::from_epsg(code).is_err();
        let ((inner, inner_messages), outer) = capture_failures(|| {
            assert!(fail(999_991));
            capture_failures(|| fail(999_992))
        });
        assert!(inner);
        assert_eq!(inner_messages, ["PROJ: proj_create_from_database: crs not found"]);
        assert_eq!(outer, ["PROJ: proj_create_from_database: crs not found"], "the inner failure is not counted twice");
        let ((), none) = capture_failures(|| ());
        assert!(none.is_empty());
    }
}
