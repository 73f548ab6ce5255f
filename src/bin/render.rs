fn main() {
    splatkit::app::render_main()
}
