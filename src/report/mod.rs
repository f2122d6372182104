//! The report module holds the report writers (charts as SVG and PNG for `powertwin reproduce`).

pub mod plot;
