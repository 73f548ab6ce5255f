fn main() {
    splatkit::app::info_main()
}
