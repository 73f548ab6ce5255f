fn main() {
    splatkit::cli::commands::splat2points_main()
}
