program spherical_pendulum
    implicit none
end program spherical_pendulum
