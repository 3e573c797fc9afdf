//! What the command line shows while it renders, and how it stops: a progress bar on a
//! terminal, a line a minute in logs, and Ctrl-C (or a scheduler's SIGTERM) ending the
//! render after the pass in flight.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;
use stokes::integrator::render::PassDone;

/// Set by the first interrupt: the render stops after the pass in flight.
pub static STOP: AtomicBool = AtomicBool::new(false);

/// On the first Ctrl-C (SIGINT; also SIGTERM and SIGHUP, as a batch scheduler sends at a
/// time limit), ask the render to stop after the pass in flight; on the second, exit at
/// once (outputs are written atomically, so no half-written file is left).
pub fn install_interrupt_handler(bar: Option<indicatif::ProgressBar>) {
    let r = ctrlc::set_handler(move || {
        if STOP.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted again: exiting without writing the image");
            std::process::exit(130);
        }
        let msg = "interrupted: finishing the pass in flight, then writing the image so far (interrupt again to quit at once)";
        match &bar {
            Some(b) => b.println(msg),
            None => eprintln!("{msg}"),
        }
    });
    if let Err(e) = r {
        eprintln!("warning: cannot catch Ctrl-C ({e}): an interrupted render will be lost");
    }
}

/// A progress bar on a terminal: `rows` rows of each of `passes` passes, or a spinner
/// under a time budget.
pub fn progress_bar(passes: Option<u32>, rows: u32) -> Option<indicatif::ProgressBar> {
    use indicatif::{ProgressBar, ProgressStyle};
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let b = match passes {
        Some(n) => ProgressBar::new(n as u64 * rows as u64).with_style(
            ProgressStyle::with_template("{spinner} {elapsed_precise} [{bar:40}] {msg}, eta {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        ),
        None => {
            let b = ProgressBar::new_spinner().with_style(
                ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            b.enable_steady_tick(std::time::Duration::from_millis(200));
            b
        }
    };
    b.set_message("0 spp");
    Some(b)
}

/// Without a terminal (logs, batch jobs): a line after the first pass, then at most one a
/// minute; `of(p)` says how far the render is.
pub fn pass_logger(of: impl Fn(&PassDone) -> String) -> impl FnMut(PassDone) {
    let mut last = Instant::now();
    move |p: PassDone| {
        if p.passes == 1 || last.elapsed().as_secs_f64() >= 60.0 {
            last = Instant::now();
            eprintln!(
                "pass {} done after {:.2} s: {}",
                p.passes,
                p.seconds,
                of(&p)
            );
        }
    }
}
