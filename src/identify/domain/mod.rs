//! The error domain falsification judges with (paper Eq. 1–4): the uncertainty table combined
//! into thresholds ([`uncertainty`]), its hard bounds ([`table_bounds`]), the bank's
//! resolution as cells ([`cells`]), the landing allowance ([`discretisation`]) and the rule
//! itself ([`falsify`]), with what a pass shares solved per instance ([`shared_gain`]). Detection, selection and the answer use it; it uses only the input.

pub(crate) mod cells;
pub(in crate::identify) mod discretisation;
pub mod falsify;
pub(crate) mod load_shapes;
pub(crate) mod shared_gain;
pub(crate) mod table_bounds;
pub(crate) mod uncertainty;
