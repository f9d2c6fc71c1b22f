//! Evaluation: the exact ground truth (`reference`: ray-cast visibility of the spherical
//! light at the camera pixels' surface points), an independent GPU estimate of it
//! (`accumulate`: Heckbert & Herf's average of hard shadows), and the error metrics of
//! DESIGN.md (`metrics`).

pub mod accumulate;
pub mod metrics;
pub mod reference;
pub mod stress;
