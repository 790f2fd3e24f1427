use clap::Parser;

fn main() {
    restore_broken_pipe_termination();
    let cli = manylights::cli::Cli::parse();
    std::process::exit(manylights::cli::run(cli));
}

/// Output piped into a reader that stops early (`manylights info SCENE | head`) ends the program
/// quietly, as it ends `cat`: SIGPIPE terminates it instead of a failed write panicking (Rust
/// ignores SIGPIPE, and `println!` panics on the broken pipe).
fn restore_broken_pipe_termination() {
    #[cfg(unix)]
    {
        use std::sync::{atomic::AtomicBool, Arc};
        let always = Arc::new(AtomicBool::new(true));
        // Registration fails only for signals that cannot be handled; SIGPIPE can.
        let _ =
            signal_hook::flag::register_conditional_default(signal_hook::consts::SIGPIPE, always);
    }
}
