fn main() {
    splatkit::app::refine_main()
}
