//! The `gpu-amcs` binary: parse the command line, call the library, print errors.

mod cli;
mod commands;

use clap::Parser;

fn main() {
    // The Vulkan loader prints "XDG_RUNTIME_DIR is invalid or not set" when probing for adapters
    // on headless machines; no display is used, so point it at the temp directory. Done before
    // any thread starts.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let cli = cli::Cli::parse();
    if let Err(e) = commands::run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(2);
    }
}
