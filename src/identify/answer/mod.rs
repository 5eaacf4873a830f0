//! What the answer says: the answer ([`identification`]; what sizing found, [`sizing`]; the
//! types they are made of, [`result`]), the candidate set's ranges per
//! wheel ([`ranges`]), severity and verdict in words ([`severity`]), and the paper's
//! baselines beside the method ([`baselines`]).

pub(in crate::identify) mod baselines;
pub(crate) mod identification;
pub mod json;
pub(in crate::identify) mod no_flat;
pub(crate) mod ranges;
pub(crate) mod refinement;
pub mod result;
pub(crate) mod severity;
pub(crate) mod sizing;
