!> category: public module (use holosym)
!! Events are the times at which functions g_k(t, q, p) of the motion cross zero,
!! located within each step of `integrate_events` and reported with the state there.
!!
!! A user extends `event_set` with the number of functions (`count`) and their values
!! (`value(k, t, q, p)`), and may override `direction(k)` (`EVENT_RISING`: g from
!! negative to positive, `EVENT_FALLING`, or `EVENT_ANY`, the default) and `terminal(k)`
!! (stop the integration at the event; default no).
!!
!! How an event is located, within the step from (t_a, q_a, p_a) to t_a + h:
!! 1. g at both ends of the step (the states the integrator returns) and at `samples` - 1
!!    interior points of the step's dense output: a sign change between two neighbours
!!    brackets a crossing (two crossings closer than h / `samples` may cancel out);
!! 2. the crossing on the dense output, by the Illinois variant of regula falsi to the
!!    working precision in tau;
!! 3. the dense output is accurate only to about h^(M+1); the time is refined by the
!!    secant method on s -> g(t_a + s, one step of the scheme of size s from
!!    (q_a, p_a)), so that the event time and state have the accuracy of the scheme's
!!    steps (order 2M, the state on the constraint manifold), on a copy of the
!!    integrator. A crossing exactly at a step's end is reported once, in the step that
!!    ends there.
!! Events within a step are reported in time order. A terminal event ends the run with
!! the state at the event (q, p returned there) and `stopped` set.
module holosym_events
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, real_str, int_str, &
        is_finite, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NONFINITE_VALUE, &
        HOLOSYM_SIZE_MISMATCH
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator, step_observer, step_info_t
    use holosym_formula_model, only: formula_model
    implicit none
    private

    public :: event_set, event_t, integrate_events, model_events

    !> `direction(k)`: crossings of g_k in either direction (default).
    integer, parameter, public :: EVENT_ANY = 0
    !> ... only from negative to positive ...
    integer, parameter, public :: EVENT_RISING = 1
    !> ... only from positive to negative.
    integer, parameter, public :: EVENT_FALLING = -1

    !> Sign changes are looked for between this many parts of each step, by default.
    integer, parameter :: default_samples = 4
    !> The secant refinement stops when a change of the event time is at most this many
    !! epsilons of the step size (or g is zero there) ...
    real(wp), parameter :: refinement_tolerance = 4 * epsilon(1.0_wp)
    !> ... or after this many steps of the scheme (superlinear from the dense output's
    !! h^(M+1): on the planar pendulum at (8, 7, 9), h = 1/16, three secant steps change
    !! the time by about 1.5e-18, 3e-34 and 6e-36).
    integer, parameter :: refinement_steps = 12

    !> The event functions of a run: extend it.
    type, abstract :: event_set
    contains
        !> Number of event functions (>= 1).
        procedure(count_interface), deferred :: count
        !> g_k(t, q, p), k = 1..count.
        procedure(value_interface), deferred :: value
        !> EVENT_ANY (default), EVENT_RISING or EVENT_FALLING for function k.
        procedure :: direction => any_direction
        !> Whether a crossing of function k ends the run (default: no).
        procedure :: terminal => not_terminal
    end type event_set

    !> One located event.
    type :: event_t
        integer :: index = 0            !! which function, 1..count
        integer :: direction = 0        !! +1: g rose through zero, -1: it fell
        logical :: terminal = .false.   !! it ended the run
        integer :: step = 0             !! the step of the run it lies in (1-based)
        real(wp) :: t = 0               !! its time
        real(wp), allocatable :: q(:), p(:) !! the state at t (a step of the scheme)
        real(wp), allocatable :: lambda(:)  !! the multipliers at t
    end type event_t

    abstract interface
        integer function count_interface(self)
            import :: event_set
            class(event_set), intent(in) :: self
        end function count_interface

        real(wp) function value_interface(self, k, t, q, p)
            import :: event_set, wp
            class(event_set), intent(in) :: self
            integer, intent(in) :: k          !! which function
            real(wp), intent(in) :: t         !! time
            real(wp), intent(in) :: q(:), p(:) !! state
        end function value_interface
    end interface

    !> The `event` statements of a model file as an `event_set`: `model_events(model)`.
    !! It points at the model, which must outlive it (and keeps its parameters' values).
    type, extends(event_set) :: model_events
        type(formula_model), pointer :: model => null()
    contains
        procedure :: count => model_event_count
        procedure :: value => model_event_value
        procedure :: direction => model_event_direction
        procedure :: terminal => model_event_terminal
    end type model_events

    !> The observer of `integrate_events`: finds the events of each step.
    type, extends(step_observer) :: locator_t
        class(event_set), pointer :: events => null()
        class(constrained_hamiltonian), pointer :: sys => null()
        type(constrained_integrator) :: probe    !! takes the refining steps
        real(wp) :: h = 0
        integer :: samples = default_samples
        real(wp), allocatable :: qa(:), pa(:), ga(:) !! the step's start and g there
        type(event_t), allocatable :: found(:)
        integer :: count = 0
        !> The run ends after this many events (as at a terminal one); huge: no limit.
        integer :: limit = huge(1)
        logical :: stopped = .false.
        type(holosym_status_t) :: status
        !> The caller's observer, called after each step (after its events are located).
        class(step_observer), pointer :: inner => null()
    contains
        procedure :: observe => locate_in_step
    end type locator_t

contains

    !> Integrate `steps` steps of size h from (q, p) as `integ%integrate` does, and locate
    !! the crossings of the event functions (see the module's description): `found` holds
    !! them in time order, `stopped` is true when a terminal event ended the run (q, p are
    !! then the state at that event, a step of the scheme; else the state after the last
    !! step). `samples` (>= 1, default 4): parts of each step searched for sign changes.
    !! `observer` (optional) is called after each step as `integrate` calls it (with the
    !! step's dense output); its halt ends the run as in `integrate` (HOLOSYM_USER_ABORT).
    !! `limit` (optional, >= 1): the run ends at the limit-th event as at a terminal one
    !! (`stopped` set, q and p the state there): a Poincare section's count of crossings.
    !! Codes: those of `integrate`; HOLOSYM_INVALID_ARGUMENT (count < 1, samples < 1,
    !! limit < 1, a
    !! direction other than EVENT_ANY, EVENT_RISING, EVENT_FALLING),
    !! HOLOSYM_SIZE_MISMATCH (q or p not of size n),
    !! HOLOSYM_NONFINITE_VALUE (an event function returned NaN or Inf: the run stops after
    !! the step where it did, with the events found before).
    subroutine integrate_events(integ, sys, q, p, h, steps, events, found, stopped, status, &
                                steps_done, start_time, samples, observer, limit)
        type(constrained_integrator), intent(inout) :: integ !! set up by `init`
        class(constrained_hamiltonian), intent(in), target :: sys !! the system
        real(wp), intent(inout) :: q(:), p(:)  !! start state in, end (or event) state out
        real(wp), intent(in) :: h              !! step size > 0
        integer, intent(in) :: steps           !! number of steps >= 0
        class(event_set), intent(in), target :: events !! the event functions
        type(event_t), allocatable, intent(out) :: found(:) !! the events, in time order
        logical, intent(out) :: stopped        !! a terminal event ended the run
        type(holosym_status_t), intent(out) :: status !! outcome
        integer, intent(out), optional :: steps_done !! whole steps completed
        real(wp), intent(in), optional :: start_time !! t of the start state (default 0)
        integer, intent(in), optional :: samples     !! parts of a step searched (>= 1)
        class(step_observer), intent(inout), target, optional :: observer !! after each step
        integer, intent(in), optional :: limit       !! end at this many events (>= 1)
        type(locator_t) :: locator
        real(wp) :: t0
        integer :: k, done

        stopped = .false.
        allocate (found(0))
        if (present(steps_done)) steps_done = 0
        t0 = 0
        if (present(start_time)) t0 = start_time
        if (present(samples)) locator%samples = samples
        if (present(observer)) locator%inner => observer
        if (present(limit)) locator%limit = limit
        if (events%count() < 1 .or. locator%samples < 1 .or. locator%limit < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "events need count >= 1, " // &
                "samples >= 1 and limit >= 1; got count " // int_str(events%count()) // &
                ", samples " // int_str(locator%samples) // ", limit " // &
                int_str(locator%limit))
            return
        end if
        do k = 1, events%count()
            select case (events%direction(k))
            case (EVENT_ANY, EVENT_RISING, EVENT_FALLING)
            case default
                call set_status(status, HOLOSYM_INVALID_ARGUMENT, "the direction of event " // &
                    "function " // int_str(k) // " must be EVENT_ANY (0), EVENT_RISING (1) " // &
                    "or EVENT_FALLING (-1); got " // int_str(events%direction(k)))
                return
            end select
        end do
        ! The event functions see the start state: its sizes first.
        if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q and p must have size n = " // &
                int_str(sys%n) // "; got " // int_str(size(q)) // " and " // int_str(size(p)))
            return
        end if
        locator%events => events
        locator%sys => sys
        locator%probe = integ
        locator%h = h
        locator%qa = q
        locator%pa = p
        allocate (locator%ga(events%count()), locator%found(0))
        do k = 1, events%count()
            locator%ga(k) = events%value(k, t0, q, p)
        end do
        if (.not. all(is_finite(locator%ga))) then
            call set_status(status, HOLOSYM_NONFINITE_VALUE, "an event function returned " // &
                "NaN or Inf at the start state")
            return
        end if
        call integ%integrate(sys, q, p, h, steps, locator, done, status, start_time=t0)
        if (present(steps_done)) steps_done = done
        found = locator%found(1:locator%count)
        ! The locator's halt is not the caller's abort: a terminal event ends the run with
        ! success, a non-finite event value with its own code.
        if (.not. locator%status%ok()) then
            status = locator%status
        else if (locator%stopped) then
            call set_status(status, HOLOSYM_SUCCESS, "")
        end if
        stopped = locator%stopped
        if (stopped) then
            q = found(size(found))%q
            p = found(size(found))%p
        end if
    end subroutine integrate_events

    !> After step `step` (from locator%qa, pa to q, p at t): the step's crossings, in time
    !! order; a terminal one (or a non-finite g) halts the run.
    subroutine locate_in_step(self, step, t, q, p, info, halt)
        class(locator_t), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t
        real(wp), intent(in) :: q(:), p(:)
        type(step_info_t), intent(in) :: info
        logical, intent(inout) :: halt
        real(wp) :: tau(0:self%samples), g(0:self%samples)
        type(event_t), allocatable :: here(:)
        integer :: k, i, first
        allocate (here(0))
        tau = [(real(i, wp) / self%samples, i = 0, self%samples)]
        do k = 1, self%events%count()
            call sampled_values(self, k, self%dense%t_start, tau, q, p, g)
            if (.not. all(is_finite(g))) then
                call set_status(self%status, HOLOSYM_NONFINITE_VALUE, "event function " // &
                    int_str(k) // " returned NaN or Inf (or its callback failed) in the " // &
                    "step ending at t = " // real_str(t))
                halt = .true.
                return
            end if
            do i = 1, self%samples
                if (.not. crossing(g(i - 1), g(i), self%events%direction(k))) cycle
                here = [here, located(self, k, step, self%dense%t_start, tau(i - 1), tau(i), &
                                      g(i - 1), g(i), q, p)]
            end do
            self%ga(k) = g(self%samples)
        end do
        call sort_by_time(here)
        first = findloc([(here(i)%terminal, i = 1, size(here))], .true., dim=1)
        ! The limit-th event of the run ends it as a terminal one does.
        if (size(here) >= self%limit - self%count .and. &
            (first == 0 .or. first > self%limit - self%count)) first = self%limit - self%count
        if (first > 0) then
            here = here(1:first)
            self%stopped = .true.
            halt = .true.
        end if
        call append(self, here)
        self%qa = q
        self%pa = p
        if (associated(self%inner)) then
            self%inner%dense = self%dense
            call self%inner%observe(step, t, q, p, info, halt)
        end if
    end subroutine locate_in_step

    !> g_k at the step's start (kept), its end (q, p) and the dense output's interior
    !! sample points.
    subroutine sampled_values(self, k, ta, tau, q, p, g)
        class(locator_t), intent(inout) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: ta, tau(0:), q(:), p(:)
        real(wp), intent(out) :: g(0:)
        integer :: i, last
        last = ubound(tau, 1)
        g(0) = self%ga(k)
        g(last) = self%events%value(k, self%dense%t_end, q, p)
        do i = 1, last - 1
            g(i) = dense_value(self, k, ta, tau(i))
        end do
    end subroutine sampled_values

    !> g_k on the step's dense output at tau.
    real(wp) function dense_value(self, k, ta, tau) result(g)
        class(locator_t), intent(inout) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: ta, tau
        real(wp) :: q(size(self%qa)), p(size(self%qa)), lambda(self%sys%m), t
        t = min(ta + tau * self%h, self%dense%t_end)
        call self%dense%evaluate(t, q, p, lambda)
        g = self%events%value(k, t, q, p)
    end function dense_value

    !> Whether g crosses zero from gl to gr in the wanted direction. A zero at the left end
    !! was the previous interval's (or step's) crossing; a zero at the right end is this
    !! interval's.
    pure logical function crossing(gl, gr, direction)
        real(wp), intent(in) :: gl, gr
        integer, intent(in) :: direction
        crossing = .false.
        if (gl == 0) return
        if (gl < 0 .and. gr >= 0) crossing = direction /= EVENT_FALLING
        if (gl > 0 .and. gr <= 0) crossing = direction /= EVENT_RISING
    end function crossing

    !> The crossing of g_k in tau in [tl, tr] of the step from (qa, pa) at ta: on the dense
    !! output (`bracketed_root`), then refined by steps of the scheme (`refined_time`).
    function located(self, k, step, ta, tl, tr, gl, gr, q, p) result(event)
        class(locator_t), intent(inout) :: self
        integer, intent(in) :: k, step
        real(wp), intent(in) :: ta, tl, tr, gl, gr, q(:), p(:)
        type(event_t) :: event
        real(wp) :: tau, q_dense(size(q)), p_dense(size(p))
        event%index = k
        event%step = step
        event%direction = merge(1, -1, gl < 0)
        event%terminal = self%events%terminal(k)
        allocate (event%lambda(self%sys%m))
        if (gr == 0 .and. tr == 1) then
            ! At the step's end: the state the integrator returned.
            event%t = self%dense%t_end
            event%q = q
            event%p = p
            call self%dense%evaluate(event%t, q_dense, p_dense, event%lambda)
            return
        end if
        tau = bracketed_root(self, k, ta, tl, tr, gl, gr)
        call refined_time(self, k, ta, tau * self%h, event)
    end function located

    !> The root of g_k on the dense output in [tl, tr] (g = gl, gr there, of opposite
    !! signs), by the Illinois method, to the working precision in tau.
    real(wp) function bracketed_root(self, k, ta, tl, tr, gl, gr) result(tau)
        class(locator_t), intent(inout) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: ta, tl, tr, gl, gr
        real(wp) :: a, b, fa, fb, fc
        integer :: side, iteration
        a = tl
        b = tr
        fa = gl
        fb = gr
        side = 0
        tau = b
        do iteration = 1, 200
            tau = (a * fb - b * fa) / (fb - fa)
            if (.not. (tau > a .and. tau < b)) tau = (a + b) / 2
            if (b - a <= 4 * epsilon(1.0_wp)) exit
            fc = dense_value(self, k, ta, tau)
            if (fc == 0) exit
            if (sign(1.0_wp, fc) == sign(1.0_wp, fb)) then
                b = tau
                fb = fc
                if (side == -1) fa = fa / 2
                side = -1
            else
                a = tau
                fa = fc
                if (side == 1) fb = fb / 2
                side = 1
            end if
        end do
    end function bracketed_root

    !> The event time ta + s with s from the secant method on s -> g_k after one step of
    !! the scheme of size s from (qa, pa), started at the dense output's estimate s0; the
    !! event's state is that step's end. Where a refining step fails, the estimate and the
    !! dense output stand.
    subroutine refined_time(self, k, ta, s0, event)
        class(locator_t), intent(inout) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: ta, s0
        type(event_t), intent(inout) :: event
        real(wp) :: s(2), g(2), next, qs(size(self%qa)), ps(size(self%qa))
        integer :: iteration
        logical :: ok
        s = [s0, s0 * (1 - sqrt(epsilon(1.0_wp)))]
        call probe_step(self, k, ta, s(1), g(1), qs, ps, ok)
        if (ok) call probe_step(self, k, ta, s(2), g(2), qs, ps, ok)
        do iteration = 1, refinement_steps
            if (.not. ok) exit
            if (g(2) == 0 .or. g(2) == g(1)) exit
            next = s(2) - g(2) * (s(2) - s(1)) / (g(2) - g(1))
            if (.not. (next > 0 .and. next <= self%h)) exit
            s = [s(2), next]
            g(1) = g(2)
            call probe_step(self, k, ta, s(2), g(2), qs, ps, ok)
            if (abs(s(2) - s(1)) <= refinement_tolerance * self%h) exit
        end do
        if (ok) then
            event%t = ta + s(2)
            event%q = qs
            event%p = ps
            call self%probe%dense_output(1.0_wp, qs, ps, event%lambda)
        else
            event%t = min(ta + s0, self%dense%t_end)
            allocate (event%q(size(qs)), event%p(size(qs)))
            call self%dense%evaluate(event%t, event%q, event%p, event%lambda)
        end if
    end subroutine refined_time

    !> One step of the scheme of size s from the step's start, on the probe; g_k at its
    !! end.
    subroutine probe_step(self, k, ta, s, g, qs, ps, ok)
        class(locator_t), intent(inout) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: ta, s
        real(wp), intent(out) :: g, qs(:), ps(:)
        logical, intent(out) :: ok
        type(holosym_status_t) :: status
        qs = self%qa
        ps = self%pa
        call self%probe%step(self%sys, qs, ps, s, status=status)
        ok = status%ok()
        g = 0
        if (ok) g = self%events%value(k, ta + s, qs, ps)
        ok = ok .and. is_finite(g)
    end subroutine probe_step

    !> Sort a step's events by time (a handful: insertion sort).
    subroutine sort_by_time(events)
        type(event_t), intent(inout) :: events(:)
        type(event_t) :: moving
        integer :: i, j
        do i = 2, size(events)
            moving = events(i)
            j = i - 1
            do while (j >= 1)
                if (events(j)%t <= moving%t) exit
                events(j + 1) = events(j)
                j = j - 1
            end do
            events(j + 1) = moving
        end do
    end subroutine sort_by_time

    !> Add a step's events to those found.
    subroutine append(self, events)
        class(locator_t), intent(inout) :: self
        type(event_t), intent(in) :: events(:)
        if (size(events) == 0) return
        self%found = [self%found(1:self%count), events]
        self%count = self%count + size(events)
    end subroutine append

    !> Default `direction`: EVENT_ANY.
    integer function any_direction(self, k)
        class(event_set), intent(in) :: self
        integer, intent(in) :: k !! which function
        if (k < 0 .and. self%count() < 0) continue
        any_direction = EVENT_ANY
    end function any_direction

    !> Default `terminal`: no.
    logical function not_terminal(self, k)
        class(event_set), intent(in) :: self
        integer, intent(in) :: k !! which function
        if (k < 0 .and. self%count() < 0) continue
        not_terminal = .false.
    end function not_terminal

    integer function model_event_count(self)
        class(model_events), intent(in) :: self
        model_event_count = self%model%event_count()
    end function model_event_count

    !> Event k of the model at (q, p) (model events do not depend on t).
    real(wp) function model_event_value(self, k, t, q, p) result(g)
        class(model_events), intent(in) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: t, q(:), p(:)
        real(wp) :: values(self%model%event_count())
        if (t /= t) continue
        call self%model%event_values(q, p, values)
        g = values(k)
    end function model_event_value

    integer function model_event_direction(self, k)
        class(model_events), intent(in) :: self
        integer, intent(in) :: k
        model_event_direction = self%model%event_direction(k)
    end function model_event_direction

    logical function model_event_terminal(self, k)
        class(model_events), intent(in) :: self
        integer, intent(in) :: k
        model_event_terminal = self%model%event_stops(k)
    end function model_event_terminal

end module holosym_events
