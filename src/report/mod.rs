//! Report writers of `powertwin reproduce`: [`results`] (`results.json`), [`markdown`]
//! (`report.md`), [`summary`] (`results.md`, the headline figures), [`figures`] (the charts)
//! and the chart renderer [`plot`] (SVG and PNG).

pub mod figures;
pub mod markdown;
pub mod plot;
pub mod results;
pub mod summary;
