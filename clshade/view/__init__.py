"""`clshade view`: a local web page to explore lighting models live (controls.py: what the
page may ask for, document.py: the scene it describes, session.py: the frames,
server.py: the HTTP and WebSocket server, static/: the page)."""
