//! The pass as the bank sees it: the measurement read and checked ([`measurement`]), its
//! perceptually important points ([`pip`]), how a series is compared ([`compare`]: sample by
//! sample or through the average), the alignment's types ([`alignment`]), and the working
//! memory the hot read uses ([`buffer`]). Putting a pass on the bank's windows and time axis
//! is the first stage ([`super::prepare`]).

pub(crate) mod alignment;
pub(crate) mod buffer;
pub mod compare;
pub(crate) mod measurement;
pub(crate) mod pip;
