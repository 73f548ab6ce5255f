fn main() {
    splatkit::cli::commands::render_main()
}
