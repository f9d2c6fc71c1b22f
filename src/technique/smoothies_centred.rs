//! # smoothies-centred — Chan & Durand 2003 with the penumbra centred on the hard edge
//!
//! (Header to be completed.)

use super::smoothies::Smoothies;
use super::{Form, TechniqueInfo};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "smoothies-centred",
    summary:
        "smoothies with inner and outer smoothies: disc-chord penumbra centred on the hard edge",
    create: |init| Smoothies::create(init, Form::Centred),
};
