//! THROW-AWAY STUB of the `reference` branch's eval module (replaced when it lands):
//! ground-truth visibility, error metrics, and the bench.

pub mod metrics;
pub mod reference;

pub mod bench;
pub mod plot;
pub mod report;
pub mod spirv;
