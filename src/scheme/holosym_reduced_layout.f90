!> category: internal module (use holosym)
!! The order of the unknowns and equations of the reduced step, and the sparsity of its
!! Newton matrix: the one place that knows where each unknown and each equation lives.
!!
!! Unknowns of the reduced step (momenta eliminated, see `holosym_reduced_scheme`):
!! z_k = q_k - q_a (k = 1..M, n each) and mu_k = h lambda_k (k = 0..M, m each).
!! Equations: D_i (i = 0..M-1, n each; i = 0 is p_a + D_0), phi(q_i) (i = 1..M, m each)
!! and the hidden constraint Phi(q_M) M^-1 D_M (m).
!!
!! Coordinates are ordered by Cuthill-McKee on their coupling graph (two coordinates are
!! coupled when the Hessian of U or a constraint involves both); each constraint follows
!! the last of its coordinates. A coordinate c then owns M consecutive unknowns
!! z_1[c]..z_M[c] and the rows D_0[c]..D_(M-1)[c]; a constraint l owns M + 1 unknowns
!! mu_0[l]..mu_M[l] and the rows phi_l(q_1)..phi_l(q_M), (Phi M^-1 D_M)_l. For a chain
!! the Newton matrix is then banded with a band independent of the chain's length.
module holosym_reduced_layout
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_INVALID_DIMENSION
    implicit none
    private

    public :: reduced_layout_t

    !> Where the unknowns and equations are, and the pattern of the Newton matrix.
    type :: reduced_layout_t
        integer :: order_m = 0 !! M
        integer :: n = 0       !! coordinates
        integer :: m = 0       !! constraints
        integer :: nx = 0      !! unknowns = equations, M n + (M + 1) m
        integer, allocatable :: z_col(:, :)    !! (n, M): unknown index of z_k[c]
        integer, allocatable :: mu_col(:, :)   !! (m, 0:M): unknown index of mu_k[l]
        integer, allocatable :: d_row(:, :)    !! (n, 0:M-1): row of D_i[c]
        integer, allocatable :: phi_row(:, :)  !! (m, M): row of phi_l(q_i)
        integer, allocatable :: v_row(:)       !! (m): row of (Phi M^-1 D_M)_l
        !> Position of each constraint in the placement order (1..m): Phi Phi^T is banded
        !! in this order when the Newton matrix is.
        integer, allocatable :: constraint_order(:)
        !> Nonzero pattern of Phi (as declared by the system): entry e is
        !! Phi(phi_rows(e), phi_cols(e)).
        integer, allocatable :: phi_rows(:), phi_cols(:)
        !> Coupled coordinates of each coordinate, itself included (compressed rows).
        integer, allocatable :: near_start(:), near(:)
        !> Constraints involving each coordinate (compressed rows).
        integer, allocatable :: cons_start(:), cons(:)
        !> Coordinates of each constraint (compressed rows).
        integer, allocatable :: coords_start(:), coords(:)
        !> Entries of Phi's pattern in each column (coordinate) and each row (constraint).
        integer, allocatable :: col_entry_start(:), col_entry(:)
        integer, allocatable :: row_entry_start(:), row_entry(:)
        !> Pattern of the Newton matrix (compressed rows, nx rows).
        integer, allocatable :: jac_start(:), jac_col(:)
        !> Pattern of d(p_b - p_a)/dx (compressed rows, n rows).
        integer, allocatable :: dp_start(:), dp_col(:)
        !> Colours of the coordinates for differences of second derivatives (at distance two
        !! in the coupling graph).
        integer, allocatable :: color(:)
        integer :: colors = 0  !! number of colours
        integer :: kl = 0      !! subdiagonals of the pattern
        integer :: ku = 0      !! superdiagonals of the pattern
        !> Second derivatives by differences along the colours: a sparse pattern was
        !! declared (Phi or Hessian of U) and the dense ones would be large.
        logical :: sparse = .false.
    contains
        !> Build the layout for a system's declared sparsity and M.
        procedure :: build => layout_build
    end type reduced_layout_t

    !> Entries of the dense second derivatives (n x n for each of d2H/dq2, d2H/dqdp,
    !! d2H/dp2 and the m constraints) up to which the Newton matrix takes them from the
    !! system's `hessian` and `constraint_hessian`, even when a sparse pattern is declared:
    !! filling that little storage costs less than the colours' gradient differences, and
    !! a system's own second derivatives (exact for model files and the built-in models)
    !! are more accurate than differences. Beyond it a declared sparsity is used.
    integer(int64), parameter :: dense_derivative_entries = 1024

contains

    !> Build the layout for M and the sparsity the system declares. Codes:
    !! HOLOSYM_INVALID_ARGUMENT when a declared pattern has an index out of range,
    !! HOLOSYM_INVALID_DIMENSION when the unknowns or the coupling graph have more entries
    !! than the default integer holds.
    subroutine layout_build(self, order_m, n, m, phi_rows, phi_cols, hess_rows, hess_cols, &
                            status)
        class(reduced_layout_t), intent(out) :: self
        integer, intent(in) :: order_m       !! M >= 1
        integer, intent(in) :: n             !! coordinates
        integer, intent(in) :: m             !! constraints
        integer, intent(in) :: phi_rows(:)   !! pattern of Phi: constraint of each entry
        integer, intent(in) :: phi_cols(:)   !! pattern of Phi: coordinate of each entry
        integer, intent(in) :: hess_rows(:)  !! pattern of the Hessian of U
        integer, intent(in) :: hess_cols(:)  !! pattern of the Hessian of U
        type(holosym_status_t), intent(out) :: status !! outcome
        integer, allocatable :: order(:)
        character(len=:), allocatable :: hint
        integer(int64) :: unknowns

        ! The default (dense) patterns have n m and n^2 entries.
        hint = ""
        if (int(n, int64) * m > huge(0) .or. int(n, int64)**2 > huge(0)) hint = &
            " (a dense default pattern of n m or n^2 entries does not fit the default " // &
            "integer for n = " // int_str(n) // ": declare the sparsity)"
        if (any(phi_rows < 1) .or. any(phi_rows > m) .or. any(phi_cols < 1) .or. &
            any(phi_cols > n) .or. size(phi_rows) /= size(phi_cols)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "constraint_sparsity returned " &
                // "an index out of range (rows 1.." // int_str(m) // ", columns 1.." // &
                int_str(n) // ") or arrays of different sizes" // hint)
            return
        end if
        if (any(hess_rows < 1) .or. any(hess_rows > n) .or. any(hess_cols < 1) .or. &
            any(hess_cols > n) .or. size(hess_rows) /= size(hess_cols)) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "potential_sparsity returned " &
                // "an index out of range (1.." // int_str(n) // ") or arrays of different " // &
                "sizes" // hint)
            return
        end if
        unknowns = int(order_m, int64) * n + (int(order_m, int64) + 1) * m
        if (unknowns > huge(0)) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "the reduced step of n = " // &
                int_str(n) // ", m = " // int_str(m) // " with M = " // int_str(order_m) // &
                " has more unknowns than the default integer holds")
            return
        end if
        self%order_m = order_m
        self%n = n
        self%m = m
        self%nx = int(unknowns)
        self%phi_rows = phi_rows
        self%phi_cols = phi_cols
        self%sparse = (size(phi_rows, kind=int64) < int(n, int64) * m .or. &
            size(hess_rows, kind=int64) < int(n, int64)**2) .and. &
            int(n, int64)**2 * (m + 3) > dense_derivative_entries
        call incidence(self)
        call coupling(self, hess_rows, hess_cols, status)
        if (.not. status%ok()) return
        order = cuthill_mckee(self%near_start, self%near)
        call place(self, order)
        call newton_pattern(self)
        call color_coordinates(self)
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine layout_build

    !> Constraints of each coordinate and coordinates of each constraint, from Phi's pattern.
    subroutine incidence(self)
        type(reduced_layout_t), intent(inout) :: self
        integer :: e
        call compress(self%n, self%phi_cols, self%phi_rows, self%cons_start, self%cons)
        call compress(self%m, self%phi_rows, self%phi_cols, self%coords_start, self%coords)
        call compress(self%n, self%phi_cols, [(e, e = 1, size(self%phi_cols))], &
                      self%col_entry_start, self%col_entry)
        call compress(self%m, self%phi_rows, [(e, e = 1, size(self%phi_rows))], &
                      self%row_entry_start, self%row_entry)
    end subroutine incidence

    !> Coordinates coupled to each coordinate: itself, the Hessian's pattern (both ways)
    !! and the coordinates sharing a constraint.
    subroutine coupling(self, hess_rows, hess_cols, status)
        type(reduced_layout_t), intent(inout) :: self
        integer, intent(in) :: hess_rows(:), hess_cols(:)
        type(holosym_status_t), intent(out) :: status
        integer, allocatable :: from(:), to(:)
        integer :: c, l, a, b, count
        integer(int64) :: pairs

        pairs = self%n + 2 * size(hess_rows, kind=int64)
        do l = 1, self%m
            pairs = pairs + int(self%coords_start(l + 1) - self%coords_start(l), int64)**2
        end do
        if (pairs > huge(0)) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "the coupling graph of the " // &
                "coordinates (declared Hessian and constraint patterns) has more entries " // &
                "than the default integer holds")
            return
        end if
        call set_status(status, HOLOSYM_SUCCESS, "")
        count = int(pairs)
        allocate (from(count), to(count))
        count = 0
        do c = 1, self%n
            call pair(c, c)
        end do
        do a = 1, size(hess_rows)
            call pair(hess_rows(a), hess_cols(a))
            call pair(hess_cols(a), hess_rows(a))
        end do
        do l = 1, self%m
            do a = self%coords_start(l), self%coords_start(l + 1) - 1
                do b = self%coords_start(l), self%coords_start(l + 1) - 1
                    call pair(self%coords(a), self%coords(b))
                end do
            end do
        end do
        call compress(self%n, from, to, self%near_start, self%near)
    contains
        subroutine pair(i, k)
            integer, intent(in) :: i, k
            count = count + 1
            from(count) = i
            to(count) = k
        end subroutine pair
    end subroutine coupling

    !> Compressed rows (without duplicates) of the pairs (from(e), to(e)), rows 1..rows.
    pure subroutine compress(rows, from, to, start, list)
        integer, intent(in) :: rows, from(:), to(:)
        integer, allocatable, intent(out) :: start(:), list(:)
        integer, allocatable :: count(:), fill(:), raw(:)
        integer :: e, r, k, kept
        logical :: seen
        allocate (count(rows), start(rows + 1), fill(rows), raw(size(from)))
        count = 0
        do e = 1, size(from)
            count(from(e)) = count(from(e)) + 1
        end do
        start(1) = 1
        do r = 1, rows
            start(r + 1) = start(r) + count(r)
        end do
        fill = start(1:rows)
        do e = 1, size(from)
            raw(fill(from(e))) = to(e)
            fill(from(e)) = fill(from(e)) + 1
        end do
        ! Drop duplicates within each row (rows are short).
        allocate (list(size(from)))
        kept = 0
        do r = 1, rows
            fill(r) = kept + 1
            do e = start(r), start(r + 1) - 1
                seen = .false.
                do k = fill(r), kept
                    if (list(k) == raw(e)) seen = .true.
                end do
                if (.not. seen) then
                    kept = kept + 1
                    list(kept) = raw(e)
                end if
            end do
        end do
        start(1:rows) = fill
        start(rows + 1) = kept + 1
        list = list(1:kept)
    end subroutine compress

    !> Cuthill-McKee order of a graph given by compressed adjacency rows: breadth-first from
    !! a vertex of least degree, neighbours by increasing degree; component by component.
    pure function cuthill_mckee(start, adjacent) result(order)
        integer, intent(in) :: start(:), adjacent(:)
        integer, allocatable :: order(:)
        integer, allocatable :: degree(:)
        logical, allocatable :: visited(:)
        integer :: vertices, head, tail, u, e, v, first, i, j, swap

        vertices = size(start) - 1
        allocate (order(vertices), degree(vertices), visited(vertices))
        do u = 1, vertices
            degree(u) = start(u + 1) - start(u)
        end do
        visited = .false.
        tail = 0
        do while (tail < vertices)
            first = minloc(degree, 1, mask=.not. visited)
            tail = tail + 1
            order(tail) = first
            visited(first) = .true.
            head = tail
            do while (head <= tail)
                u = order(head)
                head = head + 1
                i = tail + 1
                do e = start(u), start(u + 1) - 1
                    v = adjacent(e)
                    if (visited(v)) cycle
                    visited(v) = .true.
                    tail = tail + 1
                    order(tail) = v
                end do
                ! Insertion sort of the new vertices by degree (stable).
                do j = i + 1, tail
                    swap = order(j)
                    v = j - 1
                    do while (v >= i)
                        if (degree(order(v)) <= degree(swap)) exit
                        order(v + 1) = order(v)
                        v = v - 1
                    end do
                    order(v + 1) = swap
                end do
            end do
        end do
    end function cuthill_mckee

    !> Indices of unknowns and rows: coordinates in `order`, each constraint right after the
    !! last of its coordinates (constraints without coordinates first).
    subroutine place(self, order)
        type(reduced_layout_t), intent(inout) :: self
        integer, intent(in) :: order(:)
        integer, allocatable :: missing(:)
        integer :: next, k, c, l, e, mm, placed
        mm = self%order_m
        allocate (self%z_col(self%n, mm), self%mu_col(self%m, 0:mm), &
                  self%d_row(self%n, 0:mm - 1), self%phi_row(self%m, mm), self%v_row(self%m))
        allocate (missing(self%m), self%constraint_order(self%m))
        next = 0
        placed = 0
        do l = 1, self%m
            missing(l) = self%coords_start(l + 1) - self%coords_start(l)
            if (missing(l) == 0) call place_constraint(l)
        end do
        do k = 1, size(order)
            c = order(k)
            self%z_col(c, :) = [(next + k, k = 1, mm)]
            self%d_row(c, :) = [(next + 1 + k, k = 0, mm - 1)]
            next = next + mm
            do e = self%cons_start(c), self%cons_start(c + 1) - 1
                l = self%cons(e)
                missing(l) = missing(l) - 1
                if (missing(l) == 0) call place_constraint(l)
            end do
        end do
    contains
        subroutine place_constraint(l)
            integer, intent(in) :: l
            integer :: i
            self%mu_col(l, :) = [(next + 1 + i, i = 0, mm)]
            self%phi_row(l, :) = [(next + i, i = 1, mm)]
            self%v_row(l) = next + mm + 1
            next = next + mm + 1
            placed = placed + 1
            self%constraint_order(l) = placed
        end subroutine place_constraint
    end subroutine place

    !> Patterns of the Newton matrix and of d(p_b - p_a)/dx, and the bandwidths.
    subroutine newton_pattern(self)
        type(reduced_layout_t), intent(inout) :: self
        integer, allocatable :: from(:), to(:), dfrom(:), dto(:)
        integer :: count, dcount, c, i, l, e, a, r, mm
        mm = self%order_m
        allocate (from(1024), to(1024), dfrom(1024), dto(1024))
        count = 0
        dcount = 0
        do c = 1, self%n
            do i = 0, mm - 1
                call d_entries(self%d_row(c, i), c, i, from, to, count)
            end do
            ! d(p_b - p_a)/dx: like D_i, with the multipliers of every node.
            do a = self%near_start(c), self%near_start(c + 1) - 1
                do i = 1, mm
                    call add(dfrom, dto, dcount, c, self%z_col(self%near(a), i))
                end do
            end do
            do a = self%cons_start(c), self%cons_start(c + 1) - 1
                do i = 0, mm
                    call add(dfrom, dto, dcount, c, self%mu_col(self%cons(a), i))
                end do
            end do
        end do
        do l = 1, self%m
            do i = 1, mm
                do a = self%coords_start(l), self%coords_start(l + 1) - 1
                    call add(from, to, count, self%phi_row(l, i), self%z_col(self%coords(a), i))
                end do
            end do
            ! (Phi M^-1 D_M)_l: the entries of D_M[c] for each coordinate c of l.
            do a = self%coords_start(l), self%coords_start(l + 1) - 1
                call d_entries(self%v_row(l), self%coords(a), mm, from, to, count)
            end do
        end do
        call compress(self%nx, from(1:count), to(1:count), self%jac_start, self%jac_col)
        call compress(self%n, dfrom(1:dcount), dto(1:dcount), self%dp_start, self%dp_col)
        self%kl = 0
        self%ku = 0
        do r = 1, self%nx
            do e = self%jac_start(r), self%jac_start(r + 1) - 1
                self%kl = max(self%kl, r - self%jac_col(e))
                self%ku = max(self%ku, self%jac_col(e) - r)
            end do
        end do
    contains
        !> Entries of a row holding D_i[c]: z_k of the coupled coordinates, mu_i of c's
        !! constraints.
        subroutine d_entries(row, c, i, from, to, count)
            integer, intent(in) :: row, c, i
            integer, allocatable, intent(inout) :: from(:), to(:)
            integer, intent(inout) :: count
            integer :: a, k
            do a = self%near_start(c), self%near_start(c + 1) - 1
                do k = 1, mm
                    call add(from, to, count, row, self%z_col(self%near(a), k))
                end do
            end do
            do a = self%cons_start(c), self%cons_start(c + 1) - 1
                call add(from, to, count, row, self%mu_col(self%cons(a), i))
            end do
        end subroutine d_entries
    end subroutine newton_pattern

    !> Append the pair (r, c), growing the arrays when full.
    pure subroutine add(from, to, count, r, c)
        integer, allocatable, intent(inout) :: from(:), to(:)
        integer, intent(inout) :: count
        integer, intent(in) :: r, c
        integer, allocatable :: grown(:)
        integer :: capacity
        if (count == size(from)) then
            ! Doubling, computed without overflowing the default integer.
            capacity = int(min(2 * size(from, kind=int64) + 16, int(huge(0), int64)))
            allocate (grown(capacity))
            grown(1:count) = from(1:count)
            call move_alloc(grown, from)
            allocate (grown(capacity))
            grown(1:count) = to(1:count)
            call move_alloc(grown, to)
        end if
        count = count + 1
        from(count) = r
        to(count) = c
    end subroutine add

    !> Greedy colouring of the coordinates at distance two in the coupling graph: two
    !! coordinates of one colour have no coupled coordinate in common, so one difference
    !! along all coordinates of a colour gives a column of a coupled second derivative
    !! for each of them.
    subroutine color_coordinates(self)
        type(reduced_layout_t), intent(inout) :: self
        integer, allocatable :: used(:)
        integer :: c, a, b, g
        allocate (self%color(self%n), used(self%n + 1))
        used = 0
        self%color = 0
        self%colors = 0
        do c = 1, self%n
            do a = self%near_start(c), self%near_start(c + 1) - 1
                do b = self%near_start(self%near(a)), self%near_start(self%near(a) + 1) - 1
                    g = self%color(self%near(b))
                    if (g > 0) used(g) = c
                end do
            end do
            g = 1
            do while (used(g) == c)
                g = g + 1
            end do
            self%color(c) = g
            self%colors = max(self%colors, g)
        end do
    end subroutine color_coordinates

end module holosym_reduced_layout
