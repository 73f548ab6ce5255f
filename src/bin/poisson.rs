fn main() {
    splatkit::app::poisson_main()
}
