//! One field of an accumulator, as the visitor that stores, restores,
//! clears and merges accumulators hands it out.

use crate::stats::{LogHistogram, Moments};

/// One accumulator field, as [`RunAcc::visit`](super::accumulators::RunAcc::visit) hands it out.
pub enum Slot<'a> {
    Count(&'a mut u64),
    Moments(&'a mut Moments),
    Histogram(&'a mut LogHistogram),
}
