program spring_linkage
    implicit none
end program spring_linkage
