fn main() {
    splatkit::app::convert_main()
}
