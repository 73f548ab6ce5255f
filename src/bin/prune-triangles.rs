fn main() {
    splatkit::cli::commands::prune_triangles_main()
}
