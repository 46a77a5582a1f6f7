use clap::Parser;

fn main() -> std::process::ExitCode {
    // Mesa's Vulkan drivers probe Wayland when wgpu enables its surface
    // extension, and libwayland prints "error: XDG_RUNTIME_DIR is invalid"
    // on headless machines where it is unset. Any existing directory
    // silences that (no Wayland socket is there; nothing else reads it).
    // Set before any thread starts.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
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
