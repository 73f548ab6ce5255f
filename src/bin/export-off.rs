fn main() {
    splatkit::app::export_off_main()
}
