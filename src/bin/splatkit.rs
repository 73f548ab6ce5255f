fn main() {
    splatkit::cli::commands::splatkit_main()
}
