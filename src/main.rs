fn main() {
    std::process::exit(helmwatch::cli::main());
}
