fn main() {
    splatkit::app::prune_triangles_main()
}
