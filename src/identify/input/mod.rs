//! The pass as the bank sees it: the measurement read and checked ([`measurement`]), its
//! perceptually important points ([`pip`]), how a series is compared ([`compare`]: sample by
//! sample or through the average), the pass put on the bank's windows and time axis
//! ([`prepare`]), and the working memory the hot read uses ([`buffer`]).

pub(crate) mod alignment;
pub(crate) mod buffer;
pub mod compare;
pub(crate) mod measurement;
pub(crate) mod pip;
pub(in crate::identify) mod prepare;
