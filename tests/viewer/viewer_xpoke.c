/*
 * Mouse and keyboard events for test_viewer.sh, sent with XSendEvent to the
 * first top-level window whose name starts with a prefix (no xdotool or
 * XTest needed: plain Xlib). GLFW takes pointer positions from the events
 * themselves, so synthetic motion drives it like a real mouse.
 *
 * usage: viewer_xpoke PREFIX COMMAND...
 *   wait MS          wait up to MS for the window to exist (first command)
 *   move X Y         pointer to window pixel (X, Y)
 *   drag X Y N       N motion events in a straight line to (X, Y)
 *   down B, up B     press / release button B (1 left, 3 right)
 *   wheel N          N notches of the wheel (negative: down)
 *   keydown K, keyup K, key K
 *                    a key by its X keysym name (Shift_L, Control_L,
 *                    Alt_L, s); held modifiers go into later events'
 *                    state
 *   sleep MS
 * Exits 0, or 1 when the window cannot be found, a command is wrong or
 * the X server refused a request (the window is gone).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <X11/Xlib.h>
#include <X11/Xutil.h>
#include <X11/keysym.h>

static Display *dpy;
static Window win;
static int px, py;         /* pointer, window pixels */
static unsigned int state; /* modifier and button masks held */

/* Xlib's default handler exits on the first error; ours reports it and
 * lets the command fail at the end. */
static int x_failed;

static int on_x_error(Display *d, XErrorEvent *e)
{
	char text[128];
	XGetErrorText(d, e->error_code, text, sizeof(text));
	fprintf(stderr, "viewer_xpoke: X error: %s (request %u)\n", text,
	        (unsigned)e->request_code);
	x_failed = 1;
	return 0;
}

static void sleep_ms(long ms)
{
	struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
	nanosleep(&ts, NULL);
}

static Window find(Window w, const char *prefix)
{
	Window root, parent, *kids = NULL, found = 0;
	unsigned int n = 0;
	char *name = NULL;
	if (XFetchName(dpy, w, &name) && name) {
		int match = strncmp(name, prefix, strlen(prefix)) == 0;
		XFree(name);
		if (match) {
			return w;
		}
	}
	if (!XQueryTree(dpy, w, &root, &parent, &kids, &n)) {
		return 0;
	}
	for (unsigned int i = 0; i < n && !found; i++) {
		found = find(kids[i], prefix);
	}
	if (kids) {
		XFree(kids);
	}
	return found;
}

static void fill_common(XEvent *e, int type)
{
	Window child;
	int rx = px, ry = py;
	memset(e, 0, sizeof(*e));
	XTranslateCoordinates(dpy, win, DefaultRootWindow(dpy), px, py, &rx,
	                      &ry, &child);
	e->type = type;
	e->xany.display = dpy;
	e->xany.window = win;
	/* Button, motion and key events share this layout. */
	e->xbutton.root = DefaultRootWindow(dpy);
	e->xbutton.subwindow = None;
	e->xbutton.time = CurrentTime;
	e->xbutton.x = px;
	e->xbutton.y = py;
	e->xbutton.x_root = rx;
	e->xbutton.y_root = ry;
	e->xbutton.state = state;
	e->xbutton.same_screen = True;
}

static void send(XEvent *e, long mask)
{
	XSendEvent(dpy, win, True, mask, e);
	XFlush(dpy);
}

static void motion(void)
{
	XEvent e;
	fill_common(&e, MotionNotify);
	send(&e, PointerMotionMask);
}

static unsigned int button_mask(int b)
{
	return b == 1   ? Button1Mask
	       : b == 2 ? Button2Mask
	       : b == 3 ? Button3Mask
	                : 0;
}

static void button(int b, int down)
{
	XEvent e;
	fill_common(&e, down ? ButtonPress : ButtonRelease);
	e.xbutton.button = (unsigned int)b;
	send(&e, down ? ButtonPressMask : ButtonReleaseMask);
	if (down) {
		state |= button_mask(b);
	} else {
		state &= ~button_mask(b);
	}
}

static int key(const char *name, int down)
{
	KeySym sym = XStringToKeysym(name);
	XEvent e;
	unsigned int mod = 0;
	if (sym == NoSymbol) {
		fprintf(stderr, "viewer_xpoke: no key named %s\n", name);
		return -1;
	}
	fill_common(&e, down ? KeyPress : KeyRelease);
	e.xkey.keycode = XKeysymToKeycode(dpy, sym);
	send(&e, down ? KeyPressMask : KeyReleaseMask);
	if (sym == XK_Shift_L || sym == XK_Shift_R) {
		mod = ShiftMask;
	} else if (sym == XK_Control_L || sym == XK_Control_R) {
		mod = ControlMask;
	} else if (sym == XK_Alt_L || sym == XK_Alt_R) {
		/* Alt is Mod1 in the X servers' default modifier map. */
		mod = Mod1Mask;
	}
	if (down) {
		state |= mod;
	} else {
		state &= ~mod;
	}
	return 0;
}

int main(int argc, char **argv)
{
	int i = 2;
	if (argc < 3) {
		fprintf(stderr, "usage: viewer_xpoke PREFIX COMMAND...\n");
		return 1;
	}
	if (!(dpy = XOpenDisplay(NULL))) {
		fprintf(stderr, "viewer_xpoke: no display\n");
		return 1;
	}
	XSetErrorHandler(on_x_error);
	if (strcmp(argv[i], "wait") == 0 && i + 1 < argc) {
		long left = atol(argv[i + 1]);
		while (!(win = find(DefaultRootWindow(dpy), argv[1])) &&
		       left > 0) {
			sleep_ms(50);
			left -= 50;
		}
		i += 2;
	} else {
		win = find(DefaultRootWindow(dpy), argv[1]);
	}
	if (!win) {
		fprintf(stderr, "viewer_xpoke: no window named %s...\n",
		        argv[1]);
		return 1;
	}
	for (; i < argc; i++) {
		const char *c = argv[i];
		if (strcmp(c, "move") == 0 && i + 2 < argc) {
			px = atoi(argv[i + 1]);
			py = atoi(argv[i + 2]);
			motion();
			i += 2;
		} else if (strcmp(c, "drag") == 0 && i + 3 < argc) {
			int x0 = px, y0 = py, x1 = atoi(argv[i + 1]),
			    y1 = atoi(argv[i + 2]), n = atoi(argv[i + 3]);
			for (int k = 1; k <= n; k++) {
				px = x0 + (x1 - x0) * k / n;
				py = y0 + (y1 - y0) * k / n;
				motion();
				sleep_ms(15);
			}
			i += 3;
		} else if ((strcmp(c, "down") == 0 || strcmp(c, "up") == 0) &&
		           i + 1 < argc) {
			button(atoi(argv[i + 1]), c[0] == 'd');
			i++;
		} else if (strcmp(c, "wheel") == 0 && i + 1 < argc) {
			int n = atoi(argv[i + 1]);
			/* X reports wheel notches as clicks of buttons 4
			 * (up) and 5 (down). */
			for (int k = 0; k < abs(n); k++) {
				button(n > 0 ? 4 : 5, 1);
				button(n > 0 ? 4 : 5, 0);
				sleep_ms(30);
			}
			i++;
		} else if ((strcmp(c, "keydown") == 0 ||
		            strcmp(c, "keyup") == 0 || strcmp(c, "key") == 0) &&
		           i + 1 < argc) {
			const char *k = argv[i + 1];
			if ((strcmp(c, "keyup") != 0 && key(k, 1)) ||
			    (strcmp(c, "keydown") != 0 && key(k, 0))) {
				return 1;
			}
			i++;
		} else if (strcmp(c, "sleep") == 0 && i + 1 < argc) {
			sleep_ms(atol(argv[i + 1]));
			i++;
		} else {
			fprintf(stderr, "viewer_xpoke: bad command %s\n", c);
			return 1;
		}
	}
	XSync(dpy, False);
	XCloseDisplay(dpy);
	return x_failed;
}
