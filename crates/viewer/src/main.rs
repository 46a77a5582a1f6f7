use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = gazecast_viewer::Cli::parse();
    let stdout = std::io::stdout();
    match gazecast_viewer::run(cli, &mut stdout.lock()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("gazecast: {message}");
            std::process::ExitCode::FAILURE
        }
    }
}
