!> category: internal module (use holosym)
!! The order of the unknowns and equations of the general scheme (`holosym_scheme`): the
!! one place that knows where each block of unknowns sits in x and each block of
!! equations in the residual (and so in the rows and columns of the Newton matrix).
!!
!! Unknowns x, n_x = (M + N + 1) n + (M + 1) m of them, in blocks in this order:
!!   z_k = q_k - q_a (k = 1..M, n each),  w_j = p_j - p_a (j = 0..N, n each),
!!   mu_k = h lambda_k (k = 0..M, m each).
!! Equations, in blocks in this order: R_p,j (j = 0..N, n each); D_i (i = 1..M-1, n each);
!! p_a + D_0 (n); phi(q_i) (i = 1..M, m each); Phi(q_M) H_p(q_M, D_M) (m).
!!
!! Every block is contiguous, so the layout holds one offset per block: the entries of a
!! block at offset o are o + 1 .. o + n (or o + m), and entry a of the block is o + a. The
!! kernels read these offsets once per block; an index within a block is added to them.
!! The offsets are fixed-size components (room for M, N up to `max_block_order`): the
!! kernels index them without an array descriptor, and `build` allocates nothing.
module holosym_scheme_layout
    use, intrinsic :: iso_fortran_env, only: int64
    implicit none
    private

    public :: scheme_layout_t, unknown_count

    !> Largest M and N the layout has room for (holosym_scheme's max_order_m and
    !! max_order_n are this value).
    integer, parameter, public :: max_block_order = 30

    !> Offsets (0-based) of the blocks of unknowns and equations of one (M, N, G, n, m).
    type :: scheme_layout_t
        integer :: order_m = 0      !! M, degree of the displacement polynomial
        integer :: order_n = 0      !! N, degree of the momentum polynomial
        integer :: gauss_points = 0 !! G, Gauss-Legendre points
        integer :: n = 0            !! coordinates (size of a z, w or D block)
        integer :: m = 0            !! constraints (size of a mu or phi block)
        integer :: nx = 0           !! unknowns = equations
        integer :: z_at(max_block_order)         !! (1:M) offset of z_k in x
        integer :: w_at(0:max_block_order)       !! (0:N) offset of w_j in x
        integer :: mu_at(0:max_block_order)      !! (0:M) offset of mu_k in x
        integer :: rp_row_at(0:max_block_order)  !! (0:N) offset of the rows R_p,j
        !> (0:M-1) offset of the rows of D_i: i = 0 is p_a + D_0, i = 1..M-1 the interior
        !! equations (D_M has no rows of its own: it enters the last block).
        integer :: d_row_at(0:max_block_order - 1)
        integer :: phi_row_at(max_block_order)   !! (1:M) offset of the rows phi(q_i)
        integer :: v_row_at = 0                      !! offset of the rows Phi(q_M) H_p(q_M, D_M)
        !> Rows R_p,j and D_i together, (M + N + 1) n: the rows before phi(q_1), which the
        !! momentum kernels fill.
        integer :: momentum_rows = 0
        !> Multiplier unknowns mu_0..mu_M together, (M + 1) m: x(mu_at(0) + 1:) holds them
        !! node by node, an m x (0:M) array in sequence.
        integer :: multipliers = 0
    contains
        !> Set the offsets for (M, N, G) and sizes (n, m).
        procedure :: build => layout_build
    end type scheme_layout_t

contains

    !> Number of unknowns (= equations) of one step: (M+N+1) n + (M+1) m; -1 when that
    !! does not fit the default integer (or an argument is negative).
    pure integer function unknown_count(order_m, order_n, n, m)
        integer, intent(in) :: order_m !! M
        integer, intent(in) :: order_n !! N
        integer, intent(in) :: n       !! coordinates
        integer, intent(in) :: m       !! constraints
        integer(int64) :: count
        unknown_count = -1
        if (min(order_m, order_n, n, m) < 0) return
        count = (int(order_m, int64) + order_n + 1) * n + (int(order_m, int64) + 1) * m
        if (count <= huge(unknown_count)) unknown_count = int(count)
    end function unknown_count

    !> Set the offsets of every block for (M, N, G) and sizes (n, m), which the caller has
    !! checked (1 <= M <= max_block_order, 0 <= N <= max_block_order, n >= 1, 0 <= m, n_x
    !! within the default integer).
    subroutine layout_build(self, order_m, order_n, gauss_points, n, m)
        class(scheme_layout_t), intent(out) :: self
        integer, intent(in) :: order_m      !! M >= 1
        integer, intent(in) :: order_n      !! N >= 0
        integer, intent(in) :: gauss_points !! G >= 1
        integer, intent(in) :: n            !! coordinates, >= 1
        integer, intent(in) :: m            !! constraints, >= 0
        integer :: k, next
        self%order_m = order_m
        self%order_n = order_n
        self%gauss_points = gauss_points
        self%n = n
        self%m = m
        ! Unknowns: z_1..z_M, w_0..w_N, mu_0..mu_M, each block after the previous one.
        next = 0
        do k = 1, order_m
            self%z_at(k) = next
            next = next + n
        end do
        do k = 0, order_n
            self%w_at(k) = next
            next = next + n
        end do
        do k = 0, order_m
            self%mu_at(k) = next
            next = next + m
        end do
        self%nx = next
        self%multipliers = next - self%mu_at(0)
        ! Equations: R_p,0..R_p,N, D_1..D_(M-1), p_a + D_0, phi(q_1)..phi(q_M), Phi H_p.
        next = 0
        do k = 0, order_n
            self%rp_row_at(k) = next
            next = next + n
        end do
        do k = 1, order_m - 1
            self%d_row_at(k) = next
            next = next + n
        end do
        self%d_row_at(0) = next
        next = next + n
        self%momentum_rows = next
        do k = 1, order_m
            self%phi_row_at(k) = next
            next = next + m
        end do
        self%v_row_at = next
    end subroutine layout_build

end module holosym_scheme_layout
