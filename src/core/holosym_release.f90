!> category: internal module (use holosym)
!! The release of the library: `holosym_version`, exported by the façade `holosym`.
!!
!! This is the one place in the sources that names the version; it matches `version` in
!! fpm.toml (which CMake reads too), and `make check-version` compares them.
module holosym_release
    implicit none
    private

    !> Version of holosym, "MAJOR.MINOR.PATCH" (semantic versioning).
    character(len=*), parameter, public :: holosym_version = "0.2.0"

end module holosym_release
