fn main() {
    splatkit::cli::commands::chamfer_main()
}
