//! Report writers of `powertwin reproduce`: [`results`] (`results.json`), [`markdown`]
//! (`report.md`), [`figures`] (the charts) and the chart renderer [`plot`] (SVG and PNG).

pub mod figures;
pub mod markdown;
pub mod plot;
pub mod results;
