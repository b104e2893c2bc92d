!> The number formats of the bench's files and summary that the tests check: an int64 as
!! text and a ratio with two decimals below 10, one above. Internal: no stability promise.
module holosym_study_text
    use, intrinsic :: iso_fortran_env, only: int64, real64
    implicit none
    private
    public :: int64_str, ratio_text

contains

    !> An int64 as text, without blanks.
    pure function int64_str(value) result(text)
        integer(int64), intent(in) :: value !! the number
        character(len=:), allocatable :: text
        character(len=24) :: buffer
        write (buffer, '(i0)') value
        text = trim(buffer)
    end function int64_str

    !> A ratio as the bench summary writes it: two decimals below 10, one above.
    function ratio_text(ratio) result(text)
        real(real64), intent(in) :: ratio !! the ratio
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        if (ratio < 10) then
            write (buffer, '(f10.2)') ratio
        else
            write (buffer, '(f10.1)') ratio
        end if
        text = trim(adjustl(buffer))
    end function ratio_text

end module holosym_study_text
