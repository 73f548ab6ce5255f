fn main() {
    splatkit::cli::commands::decimate_main()
}
