fn main() {
    splatkit::cli::commands::clean_main()
}
