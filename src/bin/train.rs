fn main() {
    splatkit::app::train_main()
}
