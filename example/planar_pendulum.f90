program planar_pendulum
    implicit none
end program planar_pendulum
