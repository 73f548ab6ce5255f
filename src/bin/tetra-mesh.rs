fn main() {
    splatkit::app::tetra_mesh_main()
}
