fn main() {
    splatkit::app::bake_texture_main()
}
