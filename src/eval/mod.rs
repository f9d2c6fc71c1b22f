//! Evaluation: the exact ground truth (`reference`: ray-cast visibility of the spherical
//! light at the camera pixels' surface points), an independent GPU estimate of it
//! (`accumulate`: Heckbert & Herf's average of hard shadows), and the error metrics of
//! docs/DESIGN.md (`metrics`); the `softshadow bench` sweep (`bench`) with its report (`report`),
//! plot (`plot`) and SPIR-V cost table (`spirv`).

pub mod accumulate;
pub mod metrics;

pub mod bench;
pub mod compare;
pub mod plot;
pub mod report;
pub mod spirv;
pub mod stress;
