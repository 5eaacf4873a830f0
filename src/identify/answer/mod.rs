//! What the answer says: the result types ([`result`]), the candidate set's ranges per
//! wheel ([`ranges`]), severity and verdict in words ([`severity`]), and the paper's
//! baselines beside the method ([`baselines`]).

pub(in crate::identify) mod baselines;
pub mod json;
pub(in crate::identify) mod no_flat;
pub(crate) mod ranges;
pub mod result;
pub(crate) mod severity;
