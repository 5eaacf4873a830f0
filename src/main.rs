fn main() -> std::process::ExitCode {
    wheelflat::cli::main()
}
