//! What the long-running roles (scheduler, worker, adjuster) share for operations: the Prometheus metrics
//! registry ([`metrics`]), the ops listener answering `/healthz`, `/readyz` and `/metrics` ([`server`]), and
//! the JetStream heartbeat and acks ([`heartbeat`]).

pub mod heartbeat;
pub mod metrics;
pub mod server;

pub use heartbeat::{reply, with_heartbeat};
pub use metrics::{Family, Kind, Registry};
pub use server::{Ops, Probe, ready, serve_ops};
