fn main() {
    splatkit::app::tsdf_fuse_main()
}
