fn main() {
    splatkit::app::decimate_main()
}
