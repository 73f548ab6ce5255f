fn main() {
    splatkit::app::bind_gaussians_main()
}
