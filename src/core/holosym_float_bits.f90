!> category: internal module (use holosym)
!! Range checks of working-precision values read from their exponent bits: a few
!! vectorisable integer operations per value, where an ordered comparison of real128
!! values is a call into libgcc's software arithmetic (and a comparison with a NaN would
!! raise 'invalid'). Used where values must fit a real64 computation: before converting
!! to real64 (`fits_real64` in `holosym_newton`) and before the real64 sums of a lowered
!! evaluation (`holosym_scheme`). Assumes IEEE binary64 or binary128 stored in
!! little-endian 64-bit words (x86-64, AArch64).
module holosym_float_bits
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    implicit none
    private

    public :: all_below_exponent

    !> 64-bit words of one working-precision value (2 for binary128, 1 for binary64).
    integer, parameter :: words = storage_size(1.0_wp) / 64

contains

    !> Whether each of the first `count` values is below 2^`limit` in magnitude, NaN and
    !! Inf included (their own checks report them; no range check rejects them on size).
    !! `values` may be an array of any rank (sequence association).
    pure logical function all_below_exponent(values, count, limit) result(below)
        real(wp), intent(in) :: values(*)
        integer, intent(in) :: count !! how many values
        integer, intent(in) :: limit !! the binary exponent none may reach
        integer(int64) :: bits(words), mask, top
        integer :: k, shift
        if (words == 2) then
            ! binary128: 15 exponent bits, bias 16383, at bit 48 of the high word.
            mask = 32767
            top = 16383 + limit
            shift = 48
        else
            ! binary64: 11 exponent bits, bias 1023, at bit 52.
            mask = 2047
            top = 1023 + limit
            shift = 52
        end if
        below = .true.
        do k = 1, count
            bits = transfer(values(k), bits)
            associate (biased => iand(shiftr(bits(words), shift), mask))
                if (biased >= top .and. biased /= mask) then
                    below = .false.
                    return
                end if
            end associate
        end do
    end function all_below_exponent

end module holosym_float_bits
