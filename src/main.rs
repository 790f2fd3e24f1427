use clap::Parser;

fn main() {
    let cli = manylights::cli::Cli::parse();
    std::process::exit(manylights::cli::run(cli));
}
