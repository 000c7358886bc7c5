//! The system tests: the real `plumbline` binary end to end, in one process or distributed on a real
//! nats-server and S3 server, with faults and hostile inputs. A test target of `plumbline-cli` (so cargo
//! builds the binary for it); see `tests/README.md`.

mod adjust;
mod bad_inputs;
mod cadastre;
mod city;
mod city_nav;
mod distributed;
mod faults;
mod r#match;
mod navigate;
mod run;
mod simulate;
mod support;
mod trajectory;
mod validate;
mod worker;
