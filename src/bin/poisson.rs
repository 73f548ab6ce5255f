fn main() {
    splatkit::cli::commands::poisson_main()
}
