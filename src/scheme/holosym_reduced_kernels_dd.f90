!> category: internal module (use holosym)
!! The reduced step's inner sums in double-double arithmetic: the Gauss positions and the
!! node sums of its working-precision residual (holosym_reduced_kernels.inc's
!! `gauss_positions` and `node_sums`), each sum of products carried as an unevaluated
!! pair of real64 numbers (106 bits; Dekker's and Knuth's exact product and sum, no fused
!! multiply-add assumed), its inputs rounded to pairs and its results back to working
!! precision. In the real128 build this replaces most of the software real128 arithmetic
!! of a residual by real64 arithmetic; its results carry a relative error of about 2^-104
!! of the sums' terms instead of real128's 2^-113, which the step's Newton tolerance must
!! allow (`double_double_floor`).
!!
!! The constraint forces t_i and the impulse are kept in working precision; the positions
!! q~ = q_a + sum_k B(g, k) z_k are summed in pairs from q_a (as a pair) and rounded once.
!!
!! A number is stored as its two parts along the first dimension (1: the high part, 2: the
!! low part). Values beyond `dd_exponent_limit` (binary exponent) or non-finite ones are
!! not converted: `dd_fits` tells the caller to use the working-precision kernels.
module holosym_reduced_kernels_dd
    use holosym_kinds, only: wp, dp
    use holosym_float_bits, only: all_below_exponent
    use holosym_reduced_kernels_wp, only: reduced_tables, reduced_evaluation
    implicit none
    private

    public :: dd_tables_t, dd_tables_init, dd_step_tables, dd_fits
    public :: dd_gauss_positions, dd_node_sums, double_double_floor

    !> The relative Newton tolerance below which double-double sums are refused: 2^-100,
    !! 16 times their rounding (2^-104 of the terms), so that the iteration's corrections
    !! can fall below the tolerance (the step's equations then hold to their own rounding).
    real(wp), parameter :: double_double_floor = 2.0_wp**(-100)

    !> Inputs of the double-double sums must have binary exponents below this: Dekker's
    !! split multiplies by 2^27 + 1 and a product of two inputs must stay finite in real64.
    integer, parameter :: dd_exponent_limit = 480

    !> Dekker's splitting constant 2^27 + 1 (a real64 number splits into two 26-bit halves).
    real(dp), parameter :: splitter = 134217729.0_dp

    !> The tables of (M, N, G) and of the step as double-double pairs, and the work arrays
    !! of the converted inputs.
    type :: dd_tables_t
        real(dp), allocatable :: bt(:, :, :)          ! (2, M, G): B(g, k) at (k, g)
        real(dp), allocatable :: st(:, :, :)          ! (2, M, 0:M): S(i, k) at (k, i)
        real(dp), allocatable :: wb(:, :, :)          ! (2, G, 0:M): w_g B(g, i)
        real(dp), allocatable :: w(:, :)              ! (2, G): w_g
        real(dp), allocatable :: hwb(:, :, :)         ! (2, G, 0:M): h w_g B(g, i), per step
        real(dp), allocatable :: hw(:, :)             ! (2, G): h w_g, per step
        real(dp), allocatable :: mass_over_h(:, :)    ! (2, n): m_c / h, per step
        real(dp), allocatable :: qa(:, :)             ! (2, n): q_a, per step
        real(dp), allocatable :: z(:, :, :)           ! (2, n, M): z_k of the evaluation
        real(dp), allocatable :: grad(:, :)           ! (2, G): grad_g of one coordinate
    end type dd_tables_t

contains

    !> The tables of (M, N, G) as pairs, and the work arrays for n coordinates.
    subroutine dd_tables_init(tab, n, dd)
        type(reduced_tables), intent(in) :: tab
        integer, intent(in) :: n
        type(dd_tables_t), intent(out) :: dd
        integer :: mm, gg
        mm = size(tab%bt, 1)
        gg = size(tab%bt, 2)
        allocate (dd%bt(2, mm, gg), dd%st(2, mm, 0:mm), dd%wb(2, gg, 0:mm), dd%w(2, gg), &
                  dd%hwb(2, gg, 0:mm), dd%hw(2, gg), dd%mass_over_h(2, n), dd%qa(2, n), &
                  dd%z(2, n, mm), dd%grad(2, gg))
        call to_pairs(tab%bt, size(tab%bt), dd%bt)
        call to_pairs(tab%st, size(tab%st), dd%st)
        call to_pairs(tab%wb, size(tab%wb), dd%wb)
        call to_pairs(tab%w, size(tab%w), dd%w)
    end subroutine dd_tables_init

    !> The step's tables as pairs: h w_g B(g, i) and h w_g (products of pairs with h), m_c / h
    !! and q_a (from their working-precision values). `fits` says whether they are in the
    !! pairs' range (else the step sums in working precision).
    subroutine dd_step_tables(h, mass_over_h, qa, dd, fits)
        real(wp), intent(in) :: h, mass_over_h(:), qa(:)
        type(dd_tables_t), intent(inout) :: dd
        logical, intent(out) :: fits
        real(dp) :: hp(2)
        integer :: g, i
        fits = dd_fits([h], 1) .and. dd_fits(mass_over_h, size(mass_over_h)) .and. &
            dd_fits(qa, size(qa))
        if (.not. fits) return
        hp = pair(h)
        do i = 0, ubound(dd%wb, 3)
            do g = 1, size(dd%wb, 2)
                call product(hp, dd%wb(:, g, i), dd%hwb(:, g, i))
            end do
        end do
        do g = 1, size(dd%w, 2)
            call product(hp, dd%w(:, g), dd%hw(:, g))
        end do
        call to_pairs(mass_over_h, size(mass_over_h), dd%mass_over_h)
        call to_pairs(qa, size(qa), dd%qa)
    end subroutine dd_step_tables

    !> Whether `count` values (any shape) are in the range of the double-double sums:
    !! finite, binary exponents below `dd_exponent_limit` (a test of the exponent bits).
    pure logical function dd_fits(x, count) result(fits)
        integer, intent(in) :: count
        real(wp), intent(in) :: x(*)
        fits = all_below_exponent(x, count, dd_exponent_limit)
    end function dd_fits

    !> q~(tau_g) = q_a + sum_k B(g, k) z_k for every Gauss point, the sum in pairs (as
    !! `gauss_positions`). Converts ev%z into dd%z for `dd_node_sums`.
    subroutine dd_gauss_positions(dd, ev)
        type(dd_tables_t), intent(inout) :: dd
        type(reduced_evaluation), intent(inout) :: ev
        integer :: g, k, c
        real(dp) :: hi, lo
        call to_pairs(ev%z, size(ev%z), dd%z)
        do g = 1, size(dd%bt, 3)
            do c = 1, size(dd%qa, 2)
                hi = dd%qa(1, c)
                lo = dd%qa(2, c)
                do k = 1, size(dd%bt, 2)
                    call add_product(hi, lo, dd%bt(1, k, g), dd%bt(2, k, g), dd%z(1, c, k), &
                                     dd%z(2, c, k))
                end do
                ev%qg(c, g) = real(hi, wp) + real(lo, wp)
            end do
        end do
    end subroutine dd_gauss_positions

    !> `node_sums` with the sums of products in pairs: D_i = (M/h) sum_k S(i, k) z_k -
    !! h sum_g w_g B(g, i) grad_g - wl_i t_i, the impulse and Phi(q_M) M^-1 D_M, t_i and
    !! the impulse's terms in working precision. Needs dd%z from `dd_gauss_positions` of
    !! the same evaluation, and ev%grad in the range of the pairs (else the caller uses
    !! `node_sums`: `dd_fits`).
    subroutine dd_node_sums(dd, wl, inv_mass, phi_rows, phi_cols, ev)
        type(dd_tables_t), intent(inout) :: dd
        real(wp), intent(in) :: wl(0:), inv_mass(:)
        integer, intent(in) :: phi_rows(:), phi_cols(:)
        type(reduced_evaluation), intent(inout) :: ev
        integer :: i, e, c, mm
        real(wp) :: moment, wt
        logical :: gradient
        mm = size(dd%st, 2)
        do c = 1, size(ev%z, 1)
            gradient = any(ev%grad(c, :) /= 0)
            if (gradient) call row_to_pairs(ev%grad, c, dd%grad)
            moment = -wl(0) * ev%t(c, 0)
            do i = 1, mm
                wt = wl(i) * ev%t(c, i)
                ev%d(c, i) = node_sum(dd, c, i, gradient) - wt
                moment = moment - wt
            end do
            if (gradient) moment = moment - impulse_sum(dd)
            ev%dp(c) = moment
            ev%d(c, 0) = moment - sum(ev%d(c, 1:mm))
        end do
        ev%v = 0
        do e = 1, size(phi_rows)
            ev%v(phi_rows(e)) = ev%v(phi_rows(e)) + ev%pv(e, mm) * inv_mass(phi_cols(e)) * &
                ev%d(phi_cols(e), mm)
        end do
    end subroutine dd_node_sums

    !> (m_c/h) sum_k S(i, k) z_k[c] - sum_g h w_g B(g, i) grad_g[c], in pairs, rounded.
    pure real(wp) function node_sum(dd, c, i, gradient) result(total)
        type(dd_tables_t), intent(in) :: dd
        integer, intent(in) :: c, i
        logical, intent(in) :: gradient
        real(dp) :: hi, lo, s1, s2
        integer :: k, g
        s1 = 0
        s2 = 0
        do k = 1, size(dd%st, 2)
            call add_product(s1, s2, dd%st(1, k, i), dd%st(2, k, i), dd%z(1, c, k), &
                             dd%z(2, c, k))
        end do
        hi = 0
        lo = 0
        call add_product(hi, lo, dd%mass_over_h(1, c), dd%mass_over_h(2, c), s1, s2)
        if (gradient) then
            do g = 1, size(dd%hwb, 2)
                call add_product(hi, lo, dd%hwb(1, g, i), dd%hwb(2, g, i), -dd%grad(1, g), &
                                 -dd%grad(2, g))
            end do
        end if
        total = real(hi, wp) + real(lo, wp)
    end function node_sum

    !> sum_g h w_g grad_g[c] of the converted gradient, in pairs, rounded.
    pure real(wp) function impulse_sum(dd) result(total)
        type(dd_tables_t), intent(in) :: dd
        real(dp) :: hi, lo
        integer :: g
        hi = 0
        lo = 0
        do g = 1, size(dd%hw, 2)
            call add_product(hi, lo, dd%hw(1, g), dd%hw(2, g), dd%grad(1, g), dd%grad(2, g))
        end do
        total = real(hi, wp) + real(lo, wp)
    end function impulse_sum

    !> (hi, lo) += a b for pairs a = (a1, a2) and b = (b1, b2): the exact product of the high
    !! parts (Dekker) plus the cross terms, added by Knuth's exact sum and renormalized.
    pure subroutine add_product(hi, lo, a1, a2, b1, b2)
        real(dp), intent(inout) :: hi, lo
        real(dp), intent(in) :: a1, a2, b1, b2
        real(dp) :: p, e, s, t, bb
        call exact_product(a1, b1, p, e)
        e = e + (a1 * b2 + a2 * b1)
        s = hi + p
        bb = s - hi
        t = (hi - (s - bb)) + (p - bb)
        t = t + lo + e
        hi = s + t
        lo = t - (hi - s)
    end subroutine add_product

    !> The pair c = a b of pairs a and b.
    pure subroutine product(a, b, c)
        real(dp), intent(in) :: a(2), b(2)
        real(dp), intent(out) :: c(2)
        c = 0
        call add_product(c(1), c(2), a(1), a(2), b(1), b(2))
    end subroutine product

    !> p + e = a b exactly (Dekker: both factors split into 26-bit halves).
    pure subroutine exact_product(a, b, p, e)
        real(dp), intent(in) :: a, b
        real(dp), intent(out) :: p, e
        real(dp) :: t, a1, a2, b1, b2
        p = a * b
        t = splitter * a
        a1 = t - (t - a)
        a2 = a - a1
        t = splitter * b
        b1 = t - (t - b)
        b2 = b - b1
        e = ((a1 * b1 - p) + a1 * b2 + a2 * b1) + a2 * b2
    end subroutine exact_product

    !> Working-precision values (count of them, any shape) as pairs: the high part x
    !! rounded to real64, the low part the rest rounded (106 bits in all).
    pure subroutine to_pairs(x, count, pairs)
        integer, intent(in) :: count
        real(wp), intent(in) :: x(count)
        real(dp), intent(out) :: pairs(2, count)
        integer :: k
        do k = 1, count
            pairs(:, k) = pair(x(k))
        end do
    end subroutine to_pairs

    !> Row c of a working-precision matrix as pairs (no copy of the row).
    pure subroutine row_to_pairs(x, c, pairs)
        real(wp), intent(in) :: x(:, :)
        integer, intent(in) :: c
        real(dp), intent(out) :: pairs(:, :)
        integer :: k
        do k = 1, size(x, 2)
            pairs(:, k) = pair(x(c, k))
        end do
    end subroutine row_to_pairs

    !> A working-precision value as a pair: the high part x rounded to real64, the low part
    !! the rest (exact in working precision) rounded.
    pure function pair(x) result(parts)
        real(wp), intent(in) :: x
        real(dp) :: parts(2)
        parts(1) = real(x, dp)
        parts(2) = real(x - real(parts(1), wp), dp)
    end function pair

end module holosym_reduced_kernels_dd
