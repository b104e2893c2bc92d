program holosym_tests
    implicit none
    print '(a)', "0 passed, 0 failed"
end program holosym_tests
