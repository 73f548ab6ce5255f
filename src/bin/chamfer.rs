fn main() {
    splatkit::app::chamfer_main()
}
