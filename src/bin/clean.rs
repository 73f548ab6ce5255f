fn main() {
    splatkit::app::clean_main()
}
