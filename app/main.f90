program holosym_cli
    implicit none
    print '(a)', "holosym: commands to come"
end program holosym_cli
