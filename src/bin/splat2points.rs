fn main() {
    splatkit::app::splat2points_main()
}
