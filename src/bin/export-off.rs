fn main() {
    splatkit::cli::commands::export_off_main()
}
