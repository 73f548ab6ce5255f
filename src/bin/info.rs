fn main() {
    splatkit::cli::commands::info_main()
}
