//! Installing the process-wide `tracing` subscriber: pretty or JSON lines on stderr, filtered by `EnvFilter`.

use tracing_subscriber::EnvFilter;

use crate::config::{LogConfig, LogFormat};

/// Why the subscriber was not installed.
#[derive(Debug, thiserror::Error)]
pub enum TracingError {
    #[error("invalid log filter `{filter}`: {source}")]
    Filter {
        filter: String,
        #[source]
        source: tracing_subscriber::filter::ParseError,
    },
    /// A global subscriber (or `log` logger) is already installed, e.g. by an earlier call.
    #[error("tracing is already initialised: {0}")]
    AlreadyInitialised(String),
}

/// The filter directives in force: `rust_log` (the caller passes `RUST_LOG`'s value) when set and
/// non-empty, else the config's filter.
pub fn effective_filter<'a>(config: &'a LogConfig, rust_log: Option<&'a str>) -> &'a str {
    rust_log.map(str::trim).filter(|s| !s.is_empty()).unwrap_or(&config.filter)
}

/// Installs the global subscriber writing to stderr. A second call returns
/// [`TracingError::AlreadyInitialised`] instead of panicking.
pub fn init_tracing(config: &LogConfig, rust_log: Option<&str>) -> Result<(), TracingError> {
    let directives = effective_filter(config, rust_log);
    let filter = EnvFilter::try_new(directives)
        .map_err(|source| TracingError::Filter { filter: directives.to_owned(), source })?;
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let builder = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).with_ansi(ansi);
    let installed = match config.format {
        LogFormat::Pretty => builder.pretty().try_init(),
        LogFormat::Json => builder.json().try_init(),
    };
    installed.map_err(|e| TracingError::AlreadyInitialised(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(config_filter: &str, rust_log: Option<&str>, expect: &str) {
        let config = LogConfig { format: LogFormat::Json, filter: config_filter.to_owned() };
        assert_eq!(effective_filter(&config, rust_log), expect);
    }

    #[test]
    fn rust_log_overrides_the_config_filter_unless_empty() {
        check("info", None, "info");
        check("info", Some("debug,h2=warn"), "debug,h2=warn");
        check("info", Some(""), "info");
        check("warn", Some("  "), "warn");
    }
}
