//! Progress bars of long commands.

use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressStyle};
use powertwin::validation::rig::Progress;

/// One progress bar per stage.
pub struct Bars(Mutex<Option<ProgressBar>>);

impl Progress for Bars {
    fn stage(&self, name: &str, items: usize) {
        let bar = ProgressBar::new(items as u64).with_style(
            ProgressStyle::with_template("{elapsed:>4} [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_message(name.to_string());
        if let Ok(mut slot) = self.0.lock()
            && let Some(old) = slot.replace(bar)
        {
            old.finish();
        }
    }

    fn extend(&self, items: usize) {
        if let Ok(slot) = self.0.lock()
            && let Some(bar) = slot.as_ref()
        {
            bar.inc_length(items as u64);
        }
    }

    fn advance(&self) {
        if let Ok(slot) = self.0.lock()
            && let Some(bar) = slot.as_ref()
        {
            bar.inc(1);
        }
    }
}

impl Bars {
    /// No bar yet.
    pub fn new() -> Self {
        Bars(Mutex::new(None))
    }

    /// Finish the current bar.
    pub fn finish(&self) {
        if let Ok(mut slot) = self.0.lock()
            && let Some(bar) = slot.take()
        {
            bar.finish();
        }
    }
}
