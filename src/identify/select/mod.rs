//! Where to compare: the bank's predictions at the candidate points read and binned, the
//! points chosen by greedy joint entropy ([`entropy`], [`sparse`]), and the envelope windows
//! at the impact spikes ([`envelope`]).

pub(crate) mod entropy;
pub mod envelope;
pub(crate) mod sparse;
