!> category: internal module (use holosym)
!! Strict reading of decimal numbers in working precision: the one reader behind the
!! command line's numbers and the literals of model files.
!!
!! `read_decimal` checks the syntax ([sign] digits [. digits] [(e|E|d|D) [sign] digits],
!! at least one mantissa digit, nothing else) and the magnitude from the digits before
!! any conversion: 0, or 10**-R <= |x| < 10**R with R = range(1.0_wp) (4931 in real128,
!! 307 in real64). The conversion is the compiler's correctly rounded decimal read, so
!! `0.1` is the working-precision number nearest to 1/10, never a rounded double.
module holosym_decimal
    use holosym_kinds, only: wp
    implicit none
    private

    public :: read_decimal

    !> Outcomes of `read_decimal`: a number, not a number, or a number out of range.
    integer, parameter, public :: number_ok = 0, number_malformed = 1, &
        number_out_of_range = 2

contains

    !> Read a decimal real after checking its syntax and its magnitude (see the module).
    !! `outcome`: number_ok, number_malformed or number_out_of_range; `value` is 0 unless
    !! number_ok.
    subroutine read_decimal(text, value, outcome)
        character(len=*), intent(in) :: text !! candidate number
        real(wp), intent(out) :: value       !! the number when ok
        integer, intent(out) :: outcome      !! what was found
        integer :: i, mantissa_digits, exponent_digits, ios, first_digit, integer_digits
        integer :: leading, decimal_exponent, position, exponent_start
        logical :: negative_exponent
        value = 0
        outcome = number_malformed
        i = 1
        call skip_sign(text, i)
        first_digit = i
        integer_digits = count_digits(text, i)
        mantissa_digits = integer_digits
        if (i <= len(text)) then
            if (text(i:i) == ".") then
                i = i + 1
                mantissa_digits = mantissa_digits + count_digits(text, i)
            end if
        end if
        if (mantissa_digits == 0) return
        decimal_exponent = 0
        if (i <= len(text)) then
            if (scan(text(i:i), "eEdD") == 0) return
            i = i + 1
            negative_exponent = .false.
            if (i <= len(text)) negative_exponent = text(i:i) == "-"
            call skip_sign(text, i)
            exponent_start = i
            exponent_digits = count_digits(text, i)
            if (exponent_digits == 0) return
            if (i <= len(text)) return
            ! More than 9 significant exponent digits is beyond any range.
            position = verify(text(exponent_start:), "0")
            if (position /= 0) then
                if (len(text) - (exponent_start + position - 1) + 1 > 9) then
                    outcome = number_out_of_range
                    return
                end if
                read (text(exponent_start + position - 1:), *) decimal_exponent
            end if
            if (negative_exponent) decimal_exponent = -decimal_exponent
        end if
        if (i <= len(text)) return
        ! The power of ten of the first nonzero digit: digits d1 d2 ... with the point after
        ! `integer_digits` of them.
        leading = 0
        position = 0
        do i = first_digit, len(text)
            if (scan(text(i:i), "eEdD") /= 0) exit
            if (text(i:i) == ".") cycle
            position = position + 1
            if (text(i:i) /= "0") then
                leading = position
                exit
            end if
        end do
        if (leading == 0) then
            outcome = number_ok
            return
        end if
        ! 10**E <= |x| < 10**(E + 1) with E = e + integer_digits - leading.
        if (abs(decimal_exponent) > 2 * range(1.0_wp)) then
            outcome = number_out_of_range
            return
        end if
        decimal_exponent = decimal_exponent + integer_digits - leading
        if (decimal_exponent < -range(1.0_wp) .or. decimal_exponent > range(1.0_wp) - 1) then
            outcome = number_out_of_range
            return
        end if
        read (text, *, iostat=ios) value
        if (ios /= 0) then
            value = 0
            return
        end if
        outcome = number_ok
    end subroutine read_decimal

    !> Advance `i` past one '+' or '-' at text(i).
    pure subroutine skip_sign(text, i)
        character(len=*), intent(in) :: text !! the text
        integer, intent(inout) :: i          !! current position
        if (i <= len(text)) then
            if (text(i:i) == "+" .or. text(i:i) == "-") i = i + 1
        end if
    end subroutine skip_sign

    !> Count the decimal digits starting at text(i) and advance `i` past them.
    integer function count_digits(text, i) result(digits)
        character(len=*), intent(in) :: text !! the text
        integer, intent(inout) :: i          !! current position
        digits = 0
        do while (i <= len(text))
            if (verify(text(i:i), "0123456789") /= 0) exit
            digits = digits + 1
            i = i + 1
        end do
    end function count_digits

end module holosym_decimal
