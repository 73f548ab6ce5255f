fn main() {
    splatkit::app::splatkit_main()
}
